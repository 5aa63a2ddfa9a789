/* C test of the riskscore C ABI (scorer-core/ffi/include/riskscore.h), linked against the static
 * library libscorer_ffi.a. Built and run by tests/tests/ffi_c.rs:
 *
 *   ffi_test GOLDEN_CSV DRL_BLOB MSRA_BLOB THRESHOLD UNGUARDED_DRL_BLOB
 *
 * (UNGUARDED_DRL_BLOB: the DRL blob with its metadata records stripped.)
 *
 * 1. Error paths: every status code the API can return for bad arguments, bad contexts, bad blobs,
 *    bad states (non-finite, zero heading, negative size), bad track ids, NaN scores, out-of-order
 *    updates, a reset time base, full tables and unknown tracks.
 * 2. Golden parity: scores every row of the golden CSV through riskscore_score_pair and checks
 *    the features and surrogates against the reference columns (tolerances below).
 * 3. Prints every result as exact float bits with the DRL and MSRA training-domain flags ("P ..."
 *    lines) and a warning sequence ("T ..." lines) so the Rust side can compare them bit for bit
 *    with scorer-core's guarded scores on the host.
 * 4. The training-domain guard: a pair inside and a pair outside the DRL's domain, scored with
 *    the blobs as given and with the records stripped ("G ..." lines, compared on the Rust side);
 *    the stripped blob must read as inside everywhere.
 *
 * Exit status 0 when every check passed; otherwise 1, with one line per failure on stderr.
 * No malloc: the context and the blobs live in static storage.
 */
#include "riskscore.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_BLOB (64 * 1024)
#define MAX_LINE 4096
#define MAX_COLS 64

static RiskscoreContext ctx;
static RiskscoreContext other;
static uint8_t drl_blob[MAX_BLOB];
static uint8_t msra_blob[MAX_BLOB];
static uint8_t unguarded_blob[MAX_BLOB];
static uint8_t scratch[MAX_BLOB];
/* A context one byte off its alignment, to check RISKSCORE_STATUS_CONTEXT_MISALIGNED. */
static uint64_t misaligned_storage[RISKSCORE_CONTEXT_WORDS + 1];

static int failures = 0;

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            failures++;                                                                            \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);                                   \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fprintf(stderr, "\n");                                                                 \
        }                                                                                          \
    } while (0)

#define EXPECT_STATUS(call, expected)                                                              \
    do {                                                                                           \
        RiskscoreStatus got_ = (call);                                                             \
        CHECK(got_ == (expected), "%s returned %d (%s), expected %d (%s)", #call, (int)got_,        \
              riskscore_status_str(got_), (int)(expected), riskscore_status_str(expected));        \
    } while (0)

static size_t read_file(const char *path, uint8_t *buf, size_t cap) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "cannot open %s\n", path);
        exit(2);
    }
    size_t n = fread(buf, 1, cap, f);
    int more = fgetc(f) != EOF;
    fclose(f);
    if (more) {
        fprintf(stderr, "%s: larger than %d bytes\n", path, MAX_BLOB);
        exit(2);
    }
    return n;
}

static uint32_t bits(float x) {
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* CRC-32 (IEEE, reflected, as zlib and the blob header use), bit by bit. */
static uint32_t crc32_ieee(const uint8_t *p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++) {
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
    }
    return ~c;
}

static void put_le32(uint8_t *p, uint32_t v) {
    for (int k = 0; k < 4; k++) {
        p[k] = (uint8_t)(v >> (8 * k));
    }
}

/* Rewrites the header of the blob in scratch for a payload of `payload_len` bytes: its length and
 * CRC, so the load gets past the CRC check to the payload decoder. */
static void reseal(size_t payload_len) {
    put_le32(scratch + 12, (uint32_t)payload_len);
    put_le32(scratch + 16, crc32_ieee(scratch + 20, payload_len));
}

static RiskscoreWarningConfig live_config(float threshold) {
    RiskscoreWarningConfig c;
    memset(&c, 0, sizeof c);
    c.threshold = threshold;
    c.hysteresis = 0.1f * fabsf(threshold);
    c.min_on_us = 100000;
    c.stale_after_us = 1000000;
    c.latch = 0;
    c.evict_when_full = 1;
    return c;
}

static const RiskscoreVehicleState EGO = {0.0f, 0.0f, 0.0f, 20.0f, 0.0f, 1.0f, 0.0f, 4.5f, 1.8f};
static const RiskscoreVehicleState LEAD = {0.0f, 30.0f, 0.0f, 10.0f, 0.0f, 1.0f, 0.0f, 4.5f, 1.8f};

static void test_error_paths(size_t drl_len) {
    RiskscoreWarningConfig cfg = live_config(0.5f);
    RiskscorePairResult r;
    RiskscoreTrackStatus ts;
    RiskscoreTrack tr;
    RiskscoreLoadInfo info;

    CHECK(riskscore_abi_version() == RISKSCORE_ABI_VERSION, "ABI version mismatch");
    CHECK(RISKSCORE_ABI_VERSION == 2, "this test is written for ABI 2 (guarded scores, domain flags)");
    CHECK(riskscore_context_size() == RISKSCORE_CONTEXT_SIZE, "context size mismatch");
    CHECK(sizeof(RiskscoreContext) == RISKSCORE_CONTEXT_SIZE, "sizeof(RiskscoreContext)");
    CHECK(_Alignof(RiskscoreContext) >= RISKSCORE_CONTEXT_ALIGN, "alignof(RiskscoreContext)");
    CHECK(strcmp(riskscore_status_str(RISKSCORE_STATUS_MODEL_CRC_MISMATCH),
                 "model payload CRC mismatch") == 0,
          "status string");
    CHECK(strcmp(riskscore_status_str(12345), "unknown status code") == 0, "unknown status");

    /* Contexts. */
    memset(&ctx, 0xA5, sizeof ctx); /* garbage, not initialised */
    EXPECT_STATUS(riskscore_load_model(&ctx, drl_blob, drl_len, NULL),
                  RISKSCORE_STATUS_CONTEXT_NOT_INITIALIZED);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &LEAD, &r),
                  RISKSCORE_STATUS_CONTEXT_NOT_INITIALIZED);
    EXPECT_STATUS(riskscore_init(NULL, sizeof ctx, &cfg), RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, NULL), RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx - 8, &cfg), RISKSCORE_STATUS_CONTEXT_TOO_SMALL);
    RiskscoreContext *bad = (RiskscoreContext *)((uint8_t *)misaligned_storage + 4);
    EXPECT_STATUS(riskscore_init(bad, sizeof ctx, &cfg), RISKSCORE_STATUS_CONTEXT_MISALIGNED);
    EXPECT_STATUS(riskscore_score_pair(bad, &EGO, &LEAD, &r), RISKSCORE_STATUS_CONTEXT_MISALIGNED);

    /* Configurations. */
    RiskscoreWarningConfig nan_cfg = live_config(NAN);
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &nan_cfg), RISKSCORE_STATUS_INVALID_CONFIG);
    RiskscoreWarningConfig neg = live_config(0.5f);
    neg.hysteresis = -1.0f;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &neg), RISKSCORE_STATUS_INVALID_CONFIG);
    RiskscoreWarningConfig flag = live_config(0.5f);
    flag.latch = 2;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &flag), RISKSCORE_STATUS_INVALID_CONFIG);
    /* Configurations that would silently disable the warnings: no stale window (every track is
     * stale as soon as the clock moves on, so no warning persists), an infinite threshold (+inf:
     * no finite score warns; -inf: every partner warns). Refused, the context left uninitialised. */
    RiskscoreWarningConfig no_window = live_config(0.5f);
    no_window.stale_after_us = 0;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &no_window), RISKSCORE_STATUS_INVALID_CONFIG);
    uint32_t n_warn = 7, n_tracks = 7;
    EXPECT_STATUS(riskscore_any_warning(&ctx, 0, &n_warn, &n_tracks),
                  RISKSCORE_STATUS_CONTEXT_NOT_INITIALIZED);
    CHECK(n_warn == 7 && n_tracks == 7, "refused config: outputs written");
    no_window.latch = 1;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &no_window), RISKSCORE_STATUS_INVALID_CONFIG);
    RiskscoreWarningConfig inf_cfg = live_config(0.5f);
    inf_cfg.threshold = INFINITY;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &inf_cfg), RISKSCORE_STATUS_INVALID_CONFIG);
    inf_cfg.threshold = -INFINITY;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &inf_cfg), RISKSCORE_STATUS_INVALID_CONFIG);
    /* The smallest window, 1 us, is valid: a warning persists until the clock moves past it. */
    RiskscoreWarningConfig one_us = live_config(0.5f);
    one_us.stale_after_us = 1;
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &one_us), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_track_update(&ctx, 1, 1000, 0.9f, &ts), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_any_warning(&ctx, 1001, &n_warn, &n_tracks), RISKSCORE_STATUS_OK);
    CHECK(n_warn == 1 && n_tracks == 1, "1 us window: %u warnings, %u tracks", n_warn, n_tracks);
    EXPECT_STATUS(riskscore_any_warning(&ctx, 1002, &n_warn, &n_tracks), RISKSCORE_STATUS_OK);
    CHECK(n_warn == 0, "1 us window: still warning 2 us later");

    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &cfg), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &LEAD, &r), RISKSCORE_STATUS_NO_MODEL);

    /* Blobs: each corruption has its own code, and a failed load leaves the context unchanged. */
    EXPECT_STATUS(riskscore_load_model(&ctx, NULL, 10, NULL), RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_load_model(&ctx, drl_blob, 10, &info), RISKSCORE_STATUS_MODEL_TRUNCATED);
    EXPECT_STATUS(riskscore_load_model(&ctx, drl_blob, drl_len - 1, &info),
                  RISKSCORE_STATUS_MODEL_TRUNCATED);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_DRL_INT8, "truncated blob: kind %d", (int)info.kind);
    CHECK(info.expected == drl_len && info.found == drl_len - 1,
          "truncated blob: expected/found %u/%u", info.expected, info.found);
    /* The model's default threshold (calibrated in a version-2 blob, else the kind's rule). */
    float default_threshold = NAN;
    EXPECT_STATUS(riskscore_model_default_threshold(drl_blob, drl_len, &default_threshold),
                  RISKSCORE_STATUS_OK);
    CHECK(isfinite(default_threshold) && default_threshold > 0.0f,
          "default threshold %f", (double)default_threshold);
    EXPECT_STATUS(riskscore_model_default_threshold(NULL, drl_len, &default_threshold),
                  RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_model_default_threshold(drl_blob, drl_len, NULL),
                  RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_model_default_threshold(drl_blob, 10, &default_threshold),
                  RISKSCORE_STATUS_MODEL_TRUNCATED);
    memcpy(scratch, drl_blob, drl_len);
    scratch[0] = 'X';
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info), RISKSCORE_STATUS_MODEL_BAD_MAGIC);
    memcpy(scratch, drl_blob, drl_len);
    scratch[4] = 99; /* version */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_UNSUPPORTED_VERSION);
    CHECK(info.found == 99 && info.expected == RISKSCORE_NONE_U32, "version: found %u expected %u",
          info.found, info.expected);
    memcpy(scratch, drl_blob, drl_len);
    scratch[6] = 77; /* kind */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_UNKNOWN_KIND);
    CHECK(info.found == 77, "unknown kind: found %u", info.found);
    memcpy(scratch, drl_blob, drl_len);
    scratch[7] = 1; /* reserved header byte; the kind byte was read: info.kind says it */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_RESERVED_NOT_ZERO);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_DRL_INT8 && info.index == 7,
          "reserved byte: kind %d index %u", (int)info.kind, info.index);
    memcpy(scratch, drl_blob, drl_len);
    scratch[8] = 1; /* schema 1, a known schema but not the DRL's (3) */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_UNSUPPORTED_FEATURE_SCHEMA);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_DRL_INT8, "wrong schema: kind %d", (int)info.kind);
    scratch[8] = 200; /* an unknown (newer) schema */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_UNSUPPORTED_FEATURE_SCHEMA);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_DRL_INT8 && info.found == 200,
          "unknown schema: kind %d found %u", (int)info.kind, info.found);
    CHECK(strstr(riskscore_status_str(RISKSCORE_STATUS_MODEL_UNSUPPORTED_FEATURE_SCHEMA), "DRL") == NULL,
          "schema status string names one cause only");
    memcpy(scratch, drl_blob, 20);
    scratch[20] = 0x80; /* a one-byte payload with the right CRC: an unterminated varint */
    reseal(1);
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, 21, &info),
                  RISKSCORE_STATUS_MODEL_MALFORMED_PAYLOAD);
    memcpy(scratch, drl_blob, drl_len);
    scratch[21] = 200; /* first input's feature index (after the count): no feature 200 */
    reseal(drl_len - 20);
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info), RISKSCORE_STATUS_MODEL_INVALID);
    CHECK(strcmp(info.field, "inputs") == 0, "invalid model: field '%s'", info.field);
    memcpy(scratch, drl_blob, drl_len);
    scratch[drl_len / 2] ^= 0x40; /* payload bit flip */
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len, &info),
                  RISKSCORE_STATUS_MODEL_CRC_MISMATCH);
    /* expected: the CRC-32 the header stores; found: the payload's. */
    CHECK(info.expected == crc32_ieee(drl_blob + 20, drl_len - 20) &&
              info.found == crc32_ieee(scratch + 20, drl_len - 20),
          "CRC mismatch: expected %08x found %08x", info.expected, info.found);
    memcpy(scratch, drl_blob, drl_len);
    scratch[drl_len] = 0;
    EXPECT_STATUS(riskscore_load_model(&ctx, scratch, drl_len + 1, &info),
                  RISKSCORE_STATUS_MODEL_TRAILING_BYTES);
    CHECK(info.found == 1, "trailing bytes: found %u", info.found);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &LEAD, &r), RISKSCORE_STATUS_NO_MODEL);

    EXPECT_STATUS(riskscore_load_model(&ctx, drl_blob, drl_len, &info), RISKSCORE_STATUS_OK);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_DRL_INT8, "loaded kind %d", (int)info.kind);

    /* Scoring arguments. */
    EXPECT_STATUS(riskscore_score_pair(&ctx, NULL, &LEAD, &r), RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, NULL, &r), RISKSCORE_STATUS_NULL_POINTER);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &LEAD, NULL), RISKSCORE_STATUS_NULL_POINTER);
    RiskscoreVehicleState nan_state = LEAD;
    nan_state.vx = NAN;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &nan_state, &r), RISKSCORE_STATUS_NON_FINITE_STATE);
    RiskscoreVehicleState inf_state = EGO;
    inf_state.x = INFINITY;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &inf_state, &LEAD, &r), RISKSCORE_STATUS_NON_FINITE_STATE);
    /* No heading or no size: the box would be lost (a stopped car 3.45 m ahead would not warn). */
    RiskscoreVehicleState stopped = {0.0f, 8.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 4.6f, 1.9f};
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &stopped, &r), RISKSCORE_STATUS_INVALID_INPUT);
    RiskscoreVehicleState no_heading = EGO;
    no_heading.hy = 0.0f;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &no_heading, &LEAD, &r), RISKSCORE_STATUS_INVALID_INPUT);
    RiskscoreVehicleState no_size = LEAD;
    no_size.length = -4.6f;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &no_size, &r), RISKSCORE_STATUS_INVALID_INPUT);
    no_size.length = 0.0f; /* a point, as riskctl ssm scores it */
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &no_size, &r), RISKSCORE_STATUS_OK);
    no_size = LEAD;
    no_size.width = -1.8f;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &no_size, &r), RISKSCORE_STATUS_INVALID_INPUT);
    stopped.hy = 1.0f;
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &stopped, &r), RISKSCORE_STATUS_OK);
    CHECK(fabsf(r.box_distance - 3.45f) < 1e-4f, "stopped car box distance %g", r.box_distance);
    EXPECT_STATUS(riskscore_score_pair(&ctx, &EGO, &LEAD, &r), RISKSCORE_STATUS_OK);
    CHECK(r.has_drl == 1 && r.has_msra == 0 && r.has_gssm == 0, "model flags %d%d%d", r.has_drl,
          r.has_msra, r.has_gssm);
    CHECK(isnan(r.msra_score) && isfinite(r.drl_score), "scores without MSRA");
    /* Ego 20 m/s behind a 10 m/s leader, 30 m centre gap, 25.5 m box gap: TTC = 2.55 s. */
    CHECK(fabsf(r.box_distance - 25.5f) < 1e-4f, "box distance %g", r.box_distance);
    CHECK(fabsf(r.ttc2d - 2.55f) < 1e-4f, "ttc2d %g", r.ttc2d);

    /* Tracks. */
    EXPECT_STATUS(riskscore_track_update(&ctx, 1, 1000, NAN, &ts), RISKSCORE_STATUS_NAN_SCORE);
    EXPECT_STATUS(riskscore_track_get(&ctx, 1, 1000, &tr), RISKSCORE_STATUS_UNKNOWN_TRACK);
    EXPECT_STATUS(riskscore_track_update(&ctx, 1, 1000, 0.9f, &ts), RISKSCORE_STATUS_OK);
    CHECK(ts.warning == 1 && ts.event == RISKSCORE_WARNING_EVENT_ONSET && ts.new_track == 1 &&
              ts.evicted_id == RISKSCORE_NONE_U32,
          "onset status %d %d %d %u", ts.warning, ts.event, ts.new_track, ts.evicted_id);
    EXPECT_STATUS(riskscore_track_update(&ctx, 1, 999, 0.9f, &ts), RISKSCORE_STATUS_OUT_OF_ORDER);
    EXPECT_STATUS(riskscore_track_update(&ctx, 1, 2000, INFINITY, NULL), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_track_get(&ctx, 1, 2000, &tr), RISKSCORE_STATUS_OK);
    CHECK(tr.id == 1 && tr.warning == 1 && tr.stale == 0 && tr.updates == 2 && tr.onsets == 1 &&
              tr.first_warning_us == 1000 && tr.created_us == 1000 && tr.last_update_us == 2000,
          "track state");
    uint32_t warnings = 0, held = 0;
    EXPECT_STATUS(riskscore_any_warning(&ctx, 2000, &warnings, &held), RISKSCORE_STATUS_OK);
    CHECK(warnings == 1 && held == 1, "counts %u/%u", warnings, held);
    /* Stale after 1 s: no longer reported as warning. */
    EXPECT_STATUS(riskscore_track_get(&ctx, 1, 2000 + 1000001, &tr), RISKSCORE_STATUS_OK);
    CHECK(tr.stale == 1 && tr.warning == 0, "stale track still warning");
    EXPECT_STATUS(riskscore_track_remove(&ctx, 1), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_track_remove(&ctx, 1), RISKSCORE_STATUS_UNKNOWN_TRACK);
    EXPECT_STATUS(riskscore_track_update(NULL, 1, 1, 0.1f, NULL), RISKSCORE_STATUS_NULL_POINTER);
    /* RISKSCORE_NONE_U32 means "no track" in evicted_id: refused as a partner id. */
    EXPECT_STATUS(riskscore_track_update(&ctx, RISKSCORE_NONE_U32, 3000, 0.1f, &ts),
                  RISKSCORE_STATUS_INVALID_INPUT);
    EXPECT_STATUS(riskscore_track_get(&ctx, RISKSCORE_NONE_U32, 3000, &tr),
                  RISKSCORE_STATUS_UNKNOWN_TRACK);
    /* The time base restarts: a warning at t = 5000 s, then t = 1 ms. A step back within the stale
     * window is out of order; further back the track is stale and the update starts a new one. */
    EXPECT_STATUS(riskscore_track_update(&ctx, 7, 5000000000ull, 0.9f, &ts), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_track_update(&ctx, 7, 5000000000ull - 1000000, 0.1f, &ts),
                  RISKSCORE_STATUS_OUT_OF_ORDER);
    EXPECT_STATUS(riskscore_track_get(&ctx, 7, 1000, &tr), RISKSCORE_STATUS_OK);
    CHECK(tr.stale == 1 && tr.warning == 0, "clock reset: track 7 stale %d warning %d", tr.stale,
          tr.warning);
    EXPECT_STATUS(riskscore_any_warning(&ctx, 1000, &warnings, &held), RISKSCORE_STATUS_OK);
    CHECK(warnings == 0, "clock reset: %u warnings", warnings);
    EXPECT_STATUS(riskscore_track_update(&ctx, 7, 1000, 0.1f, &ts), RISKSCORE_STATUS_OK);
    CHECK(ts.new_track == 1 && ts.warning == 0, "clock reset: new %d warning %d", ts.new_track,
          ts.warning);
    EXPECT_STATUS(riskscore_track_remove(&ctx, 7), RISKSCORE_STATUS_OK);

    /* Full table with the reject policy, and eviction with the evict policy. */
    RiskscoreWarningConfig reject = live_config(0.5f);
    reject.evict_when_full = 0;
    EXPECT_STATUS(riskscore_init(&other, sizeof other, &reject), RISKSCORE_STATUS_OK);
    for (uint32_t id = 0; id < RISKSCORE_MAX_TRACKS; id++) {
        EXPECT_STATUS(riskscore_track_update(&other, id, 10, 0.1f, NULL), RISKSCORE_STATUS_OK);
    }
    EXPECT_STATUS(riskscore_track_update(&other, 1000, 10, 0.1f, NULL), RISKSCORE_STATUS_TABLE_FULL);
    RiskscoreWarningConfig evict = live_config(0.5f);
    EXPECT_STATUS(riskscore_init(&other, sizeof other, &evict), RISKSCORE_STATUS_OK);
    for (uint32_t id = 0; id < RISKSCORE_MAX_TRACKS; id++) {
        EXPECT_STATUS(riskscore_track_update(&other, id, 10 + id, 0.1f, NULL), RISKSCORE_STATUS_OK);
    }
    EXPECT_STATUS(riskscore_track_update(&other, 1000, 100, 0.1f, &ts), RISKSCORE_STATUS_OK);
    CHECK(ts.evicted_id == 0 && ts.new_track == 1, "evicted %u", ts.evicted_id);
    /* A reset time base with a table full of warning tracks: none is reported as warning, none is
     * evicted (TABLE_FULL), until they are removed (the header's stale_after_us and TABLE_FULL). */
    EXPECT_STATUS(riskscore_init(&other, sizeof other, &evict), RISKSCORE_STATUS_OK);
    for (uint32_t id = 0; id < RISKSCORE_MAX_TRACKS; id++) {
        EXPECT_STATUS(riskscore_track_update(&other, id, 5000000000ull, 0.9f, NULL),
                      RISKSCORE_STATUS_OK);
    }
    EXPECT_STATUS(riskscore_any_warning(&other, 1000, &warnings, &held), RISKSCORE_STATUS_OK);
    CHECK(warnings == 0 && held == RISKSCORE_MAX_TRACKS, "reset, full: %u warnings, %u held",
          warnings, held);
    EXPECT_STATUS(riskscore_track_update(&other, 1000, 1000, 0.1f, NULL), RISKSCORE_STATUS_TABLE_FULL);
    EXPECT_STATUS(riskscore_track_remove(&other, 5), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_track_update(&other, 1000, 1000, 0.1f, &ts), RISKSCORE_STATUS_OK);
    CHECK(ts.new_track == 1 && ts.evicted_id == RISKSCORE_NONE_U32, "reset, removed: evicted %u",
          ts.evicted_id);
    /* The 31 tracks left ahead are still held after another id's update. */
    EXPECT_STATUS(riskscore_any_warning(&other, 1000, &warnings, &held), RISKSCORE_STATUS_OK);
    CHECK(warnings == 0 && held == RISKSCORE_MAX_TRACKS, "reset, after an update: %u warnings, %u held",
          warnings, held);
}

/* Splits a CSV line in place. */
static int split(char *line, char **cols) {
    int n = 0;
    char *p = line;
    cols[n++] = p;
    for (; *p && n < MAX_COLS; p++) {
        if (*p == ',') {
            *p = '\0';
            cols[n++] = p + 1;
        } else if (*p == '\n' || *p == '\r') {
            *p = '\0';
        }
    }
    return n;
}

static int column(char **header, int n, const char *name) {
    for (int i = 0; i < n; i++) {
        if (strcmp(header[i], name) == 0) {
            return i;
        }
    }
    fprintf(stderr, "golden CSV: no column %s\n", name);
    exit(2);
}

/* |got - want| within a relative tolerance `rel` or an absolute one `abs_tol`; infinities must
 * match exactly. The reference is float64; the core computes in f32. */
static int near(double got, double want, double rel, double abs_tol) {
    if (isinf(want) || isinf(got)) {
        return got == want;
    }
    return fabs(got - want) <= abs_tol || fabs(got - want) <= rel * fabs(want);
}

static void test_golden(const char *path) {
    static char line[MAX_LINE];
    static char header_line[MAX_LINE];
    char *header[MAX_COLS];
    char *cols[MAX_COLS];
    FILE *f = fopen(path, "r");
    if (!f || !fgets(header_line, sizeof header_line, f)) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(2);
    }
    int nh = split(header_line, header);
    static const char *fields[9] = {"x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"};
    int in_col[18];
    char name[32];
    for (int s = 0; s < 2; s++) {
        for (int k = 0; k < 9; k++) {
            snprintf(name, sizeof name, "%s_%s", fields[k], s == 0 ? "i" : "j");
            in_col[s * 9 + k] = column(header, nh, name);
        }
    }
    static const char *feature_cols[RISKSCORE_FEATURE_COUNT] = {
        "f_l_ego",  "f_l_sur",  "f_w_comb",     "f_vy_ego",  "f_vx_sur",   "f_vy_sur", "f_v_ego2",
        "f_v_sur2", "f_delta_v2", "f_delta_v", "f_psi_sur", "f_rho",      "f_s"};
    int f_col[RISKSCORE_FEATURE_COUNT];
    for (int k = 0; k < RISKSCORE_FEATURE_COUNT; k++) {
        f_col[k] = column(header, nh, feature_cols[k]);
    }
    int case_col = column(header, nh, "case");
    int d_col = column(header, nh, "CurrentD");
    int ttc_col = column(header, nh, "TTC2D");
    int tadv_col = column(header, nh, "TAdv");
    int ei_col = column(header, nh, "EI");

    int line_no = 1, rows = 0, far = 0, outside = 0;
    while (fgets(line, sizeof line, f)) {
        line_no++;
        int n = split(line, cols);
        if (n < nh) {
            fprintf(stderr, "%s line %d: %d fields, header has %d\n", path, line_no, n, nh);
            exit(2);
        }
        float v[18];
        for (int k = 0; k < 18; k++) {
            v[k] = strtof(cols[in_col[k]], NULL);
        }
        RiskscoreVehicleState ego = {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]};
        RiskscoreVehicleState par = {v[9], v[10], v[11], v[12], v[13], v[14], v[15], v[16], v[17]};
        RiskscorePairResult r;
        RiskscoreStatus st = riskscore_score_pair(&ctx, &ego, &par, &r);
        CHECK(st == RISKSCORE_STATUS_OK, "line %d: score_pair %s", line_no, riskscore_status_str(st));
        if (st != RISKSCORE_STATUS_OK) {
            continue;
        }
        rows++;
        /* Features: plain f32 arithmetic on the inputs. Angles near +-pi may legitimately wrap. */
        for (int k = 0; k < RISKSCORE_FEATURE_COUNT; k++) {
            double want = strtod(cols[f_col[k]], NULL);
            int ok = near(r.features[k], want, 1e-4, 1e-3);
            if (!ok && (k == 10 || k == 11)) {
                ok = fabs(fabs(r.features[k]) - M_PI) < 1e-3 && fabs(fabs(want) - M_PI) < 1e-3;
            }
            CHECK(ok, "line %d (%s): feature %s = %.9g, golden %.9g", line_no, cols[case_col],
                  feature_cols[k], r.features[k], want);
        }
        CHECK(near(r.box_distance, strtod(cols[d_col], NULL), 1e-4, 1e-3),
              "line %d (%s): box distance %.9g, golden %s", line_no, cols[case_col], r.box_distance,
              cols[d_col]);
        /* Surrogates are compared loosely here (f32 vs the float64 reference; the exact contract
         * is scorer-core's own golden test). Near-threshold rows may flip between conflict and
         * no conflict; they are counted, and must stay rare. */
        double want_ttc = strtod(cols[ttc_col], NULL);
        double want_tadv = strtod(cols[tadv_col], NULL);
        double want_ei = strtod(cols[ei_col], NULL);
        int ok_s = near(r.ttc2d, want_ttc, 1e-3, 1e-3) && near(r.tadv, want_tadv, 1e-3, 1e-3) &&
                   near(r.ei, want_ei, 1e-3, 1e-3);
        if (!ok_s) {
            far++;
            fprintf(stderr, "note: line %d (%s): ttc2d %.7g/%s tadv %.7g/%s ei %.7g/%s\n", line_no,
                    cols[case_col], r.ttc2d, cols[ttc_col], r.tadv, cols[tadv_col], r.ei,
                    cols[ei_col]);
        }
        printf("P %d", line_no);
        for (int k = 0; k < RISKSCORE_FEATURE_COUNT; k++) {
            printf(" %08x", bits(r.features[k]));
        }
        printf(" %08x %08x %08x %08x %08x %08x %u %u\n", bits(r.box_distance), bits(r.ttc2d),
               bits(r.tadv), bits(r.ei), bits(r.drl_score), bits(r.msra_score), r.drl_in_domain,
               r.msra_in_domain);
        CHECK(r.drl_in_domain <= 1 && r.msra_in_domain <= 1 && r.gssm_in_domain == 1,
              "line %d: domain flags %u %u %u", line_no, r.drl_in_domain, r.msra_in_domain,
              r.gssm_in_domain);
        outside += r.drl_in_domain == 0;

        /* Warning sequence: three partners in turn, 40 ms apart, on the DRL score. */
        uint32_t id = (uint32_t)(rows % 3) + 1;
        uint64_t now = (uint64_t)rows * 40000u;
        RiskscoreTrackStatus ts;
        st = riskscore_track_update(&ctx, id, now, r.drl_score, &ts);
        CHECK(st == RISKSCORE_STATUS_OK, "line %d: track_update %s", line_no, riskscore_status_str(st));
        printf("T %u %llu %08x %u %u %u %u\n", id, (unsigned long long)now, bits(r.drl_score),
               ts.warning, (unsigned)ts.event, ts.new_track, ts.evicted_id);
    }
    fclose(f);
    CHECK(rows > 1000, "only %d golden rows", rows);
    CHECK(far * 100 <= rows, "%d of %d rows disagree with the golden surrogates", far, rows);
    fprintf(stderr, "golden: %d rows scored, %d with a surrogate outside 1e-3, %d outside the DRL's "
                    "training domain\n",
            rows, far, outside);
}

/* Ego 30 m/s, 60 m behind an 18.75 m articulated truck at 22 m/s (longer than any partner the
 * shipped models were trained on), and the everyday follower EGO/LEAD. */
static const RiskscoreVehicleState TRUCK_EGO = {0.0f, 0.0f, 0.0f, 30.0f, 0.0f, 1.0f, 0.0f, 4.5f, 1.8f};
static const RiskscoreVehicleState LONG_TRUCK = {0.0f, 60.0f, 0.0f, 22.0f, 0.0f, 1.0f, 0.0f, 18.75f, 2.55f};

/* One "G <pair> <blobs> <18 state bits: ego, partner> <drl bits> <drl in> <msra bits> <msra in>"
 * line (the states as given, so the Rust side scores exactly this pair). */
static void print_guarded(RiskscoreContext *c, const char *pair, const char *blobs,
                          const RiskscoreVehicleState *ego, const RiskscoreVehicleState *partner) {
    RiskscorePairResult r;
    EXPECT_STATUS(riskscore_score_pair(c, ego, partner, &r), RISKSCORE_STATUS_OK);
    printf("G %s %s", pair, blobs);
    const RiskscoreVehicleState *states[2] = {ego, partner};
    for (int k = 0; k < 2; k++) {
        const RiskscoreVehicleState *v = states[k];
        const float fields[9] = {v->x, v->y, v->vx, v->vy, v->hx, v->hy, v->acc, v->length, v->width};
        for (int f = 0; f < 9; f++) {
            printf(" %08x", bits(fields[f]));
        }
    }
    printf(" %08x %u %08x %u\n", bits(r.drl_score), r.drl_in_domain, bits(r.msra_score),
           r.msra_in_domain);
    CHECK(r.gssm_in_domain == 1 && r.has_gssm == 0, "%s %s: no GSSM loaded, gssm_in_domain %u",
          pair, blobs, r.gssm_in_domain);
}

/* `ctx` holds the DRL and MSRA blobs as given; `other` gets the DRL blob without its records. */
static void test_guard(size_t unguarded_len) {
    print_guarded(&ctx, "inside", "given", &EGO, &LEAD);
    print_guarded(&ctx, "outside", "given", &TRUCK_EGO, &LONG_TRUCK);

    RiskscoreWarningConfig cfg = live_config(0.5f);
    EXPECT_STATUS(riskscore_init(&other, sizeof other, &cfg), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_load_model(&other, unguarded_blob, unguarded_len, NULL),
                  RISKSCORE_STATUS_OK);
    const RiskscoreVehicleState *pairs[2][2] = {{&EGO, &LEAD}, {&TRUCK_EGO, &LONG_TRUCK}};
    for (int k = 0; k < 2; k++) {
        RiskscorePairResult r;
        EXPECT_STATUS(riskscore_score_pair(&other, pairs[k][0], pairs[k][1], &r), RISKSCORE_STATUS_OK);
        CHECK(r.drl_in_domain == 1, "a blob without records is inside everywhere (pair %d)", k);
        CHECK(r.has_msra == 0 && isnan(r.msra_score) && r.msra_in_domain == 1,
              "no MSRA loaded: NaN score, inside (pair %d)", k);
    }
    print_guarded(&other, "inside", "unguarded", &EGO, &LEAD);
    print_guarded(&other, "outside", "unguarded", &TRUCK_EGO, &LONG_TRUCK);
}

int main(int argc, char **argv) {
    if (argc != 6) {
        fprintf(stderr, "usage: %s GOLDEN_CSV DRL_BLOB MSRA_BLOB THRESHOLD UNGUARDED_DRL_BLOB\n",
                argv[0]);
        return 2;
    }
    size_t drl_len = read_file(argv[2], drl_blob, MAX_BLOB - 1);
    size_t msra_len = read_file(argv[3], msra_blob, MAX_BLOB);
    float threshold = strtof(argv[4], NULL);
    size_t unguarded_len = read_file(argv[5], unguarded_blob, MAX_BLOB);

    test_error_paths(drl_len);

    RiskscoreWarningConfig cfg = live_config(threshold);
    EXPECT_STATUS(riskscore_init(&ctx, sizeof ctx, &cfg), RISKSCORE_STATUS_OK);
    RiskscoreLoadInfo info;
    EXPECT_STATUS(riskscore_load_model(&ctx, drl_blob, drl_len, &info), RISKSCORE_STATUS_OK);
    EXPECT_STATUS(riskscore_load_model(&ctx, msra_blob, msra_len, &info), RISKSCORE_STATUS_OK);
    CHECK(info.kind == RISKSCORE_MODEL_KIND_MSRA, "MSRA kind %d", (int)info.kind);
    printf("C threshold %08x hysteresis %08x\n", bits(cfg.threshold), bits(cfg.hysteresis));
    test_golden(argv[1]);
    test_guard(unguarded_len);

    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("OK\n");
    return 0;
}
