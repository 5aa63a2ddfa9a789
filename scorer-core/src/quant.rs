//! Fixed-point arithmetic of the int8 network, shared bit for bit by the MCU and the host quantiser.
//!
//! Conventions (the host quantiser in `host-tools` calls these very functions):
//! - A real multiplier `M > 0` is stored as `(multiplier, shift)` with `multiplier` in
//!   `[2^30, 2^31)` and `M = multiplier * 2^-(31 + shift)`; `shift` is a right shift (negative means
//!   a left shift) in [`SHIFT_MIN`, `SHIFT_MAX`]. Because an `f32` mantissa has 24 bits,
//!   [`quantize_multiplier`] is exact: the pair represents the `f32` value without error.
//! - [`requantize`] computes `acc * multiplier / 2^(31 + shift)` in 64-bit integers with a
//!   **single** rounding, **round half away from zero** (so `-2.5 -> -3`, `2.5 -> 3`), and saturates
//!   to the `i32` range. There is no intermediate (double) rounding as in the gemmlowp
//!   `SaturatingRoundingDoublingHighMul` + `RoundingDivideByPOT` pair.
//! - Every float-to-integer conversion here ([`quantize_input`], [`quantize_weight`],
//!   [`quantize_bias`]) rounds half away from zero exactly as `libm::roundf`, then clamps
//!   ([`quantize_input`] computes the same bits without calling it; a test checks they agree).
//! - Activations are asymmetric int8: `real = scale * (q - zero_point)`. Weights are symmetric int8
//!   per output channel in `[-127, 127]`: `real = scale_j * q`. Biases are int32 in the accumulator
//!   scale `input_scale * weight_scale_j`.

/// Smallest stored right shift: `M = multiplier * 2^1 >= 2^31`, which saturates any non-zero input.
pub const SHIFT_MIN: i8 = -32;
/// Largest stored right shift: `M < 2^-32`; larger shifts would round every `i32` input to zero.
pub const SHIFT_MAX: i8 = 32;
/// Smallest valid stored multiplier (`2^30`, i.e. a mantissa of 0.5).
pub const MULTIPLIER_MIN: i32 = 1 << 30;

/// Splits a positive real multiplier into `(multiplier, shift)`, `multiplier` in `[2^30, 2^31)`, with
/// `real == multiplier * 2^-(31 + shift)` exactly.
///
/// Out-of-domain inputs: zero, negative, NaN or infinite `real` returns `(0, 0)` (a multiplier that
/// maps every accumulator to 0, and that model validation rejects); `real < 2^-33` also returns
/// `(0, 0)` because every `i32` accumulator would round to 0 anyway; `real >= 2^32` returns
/// `(2^30, -32)` (i.e. `2^31`), which saturates every non-zero accumulator exactly as the real
/// product would.
pub fn quantize_multiplier(real: f32) -> (i32, i8) {
    if !(real.is_finite() && real > 0.0) {
        return (0, 0);
    }
    let (mantissa, exponent) = libm::frexpf(real); // real = mantissa * 2^exponent, mantissa in [0.5, 1)
    let shift = -exponent;
    if shift > i32::from(SHIFT_MAX) {
        return (0, 0);
    }
    if shift < i32::from(SHIFT_MIN) {
        return (MULTIPLIER_MIN, SHIFT_MIN);
    }
    // mantissa has 24 significant bits, so mantissa * 2^31 is an integer in [2^30, 2^31): exact.
    let multiplier = (f64::from(mantissa) * 2_147_483_648.0) as i32;
    (multiplier, shift as i8)
}

/// The real value a `(multiplier, shift)` pair represents, in `f64` (exact for valid pairs).
pub fn multiplier_to_real(multiplier: i32, shift: i8) -> f64 {
    let total = 31 + i32::from(shift);
    f64::from(multiplier) * libm::exp2(-f64::from(total))
}

/// True when `(multiplier, shift)` is in the canonical range produced by [`quantize_multiplier`] for a
/// positive real: `multiplier` in `[2^30, 2^31)` and `shift` in [`SHIFT_MIN`, `SHIFT_MAX`].
pub fn is_valid_multiplier(multiplier: i32, shift: i8) -> bool {
    multiplier >= MULTIPLIER_MIN && (SHIFT_MIN..=SHIFT_MAX).contains(&shift)
}

/// `acc * multiplier / 2^(31 + shift)`, one rounding (half away from zero), saturated to `i32`.
///
/// Defined (and panic free) for every input, including negative multipliers and shifts outside the
/// canonical range; only the canonical range is ever produced by [`quantize_multiplier`].
pub fn requantize(acc: i32, multiplier: i32, shift: i8) -> i32 {
    let product = i64::from(acc) * i64::from(multiplier); // |product| <= 2^62: no overflow
    let negative = product < 0;
    let magnitude = product.unsigned_abs(); // <= 2^62
    let total = 31 + i32::from(shift);
    let rounded: u64 = if total > 0 {
        if total >= 64 {
            0 // magnitude <= 2^62 < 2^63 = half of 2^64: rounds to zero
        } else {
            let half = 1u64 << (total - 1); // <= 2^62, so magnitude + half <= 2^63: no overflow
            (magnitude + half) >> total
        }
    } else if total == 0 {
        magnitude
    } else {
        let left = total.unsigned_abs();
        if left >= 63 {
            if magnitude == 0 {
                0
            } else {
                u64::MAX
            }
        } else {
            magnitude.saturating_mul(1u64 << left)
        }
    };
    if negative {
        if rounded >= 1u64 << 31 {
            i32::MIN
        } else {
            -(rounded as i32)
        }
    } else if rounded > i32::MAX as u64 {
        i32::MAX
    } else {
        rounded as i32
    }
}

/// Requantises an int32 accumulator to an int8 activation: `requantize`, add the output zero point,
/// clamp to `[-128, 127]`, and (fused ReLU) clamp below at the zero point, which encodes real 0.
pub fn requantize_to_i8(acc: i32, multiplier: i32, shift: i8, zero_point: i8, relu: bool) -> i8 {
    let scaled = requantize(acc, multiplier, shift).saturating_add(i32::from(zero_point));
    let low = if relu { i32::from(zero_point) } else { -128 };
    scaled.clamp(low, 127) as i8
}

/// Quantises one raw (unstandardised) feature to the int8 input of the network:
/// `clamp(roundf(x * mul + add), -128, 127)`, where `(mul, add)` fold the feature standardisation
/// and the input quantisation together (see [`fold_standardisation`]).
///
/// `x = NaN` (or a NaN from `x * mul + add`) maps to `zero_point`, the code of a standardised 0,
/// i.e. the training mean of the feature. `+-inf` clamps to the int8 bounds.
pub fn quantize_input(x: f32, mul: f32, add: f32, zero_point: i8) -> i8 {
    let v = x * mul + add;
    if v.is_nan() {
        return zero_point;
    }
    // `roundf(v).clamp(-128, 127)`, cheaper (this runs per input on the MCU): clamping first is
    // the same because the bounds are integers and rounding is monotone; then `t = trunc(c)` is
    // exact and so is `c - t` (Sterbenz), and a fraction of magnitude >= 0.5 rounds away from 0.
    let c = v.clamp(-128.0, 127.0);
    let t = c as i32;
    let fraction = c - t as f32;
    let rounded = if fraction >= 0.5 {
        t + 1
    } else if fraction <= -0.5 {
        t - 1
    } else {
        t
    };
    rounded as i8
}

/// Folds `z = (x - mean) / std` followed by `q = z / scale + zero_point` into `q = x * mul + add`:
/// `mul = 1 / (std * scale)`, `add = zero_point - mean * mul` (all in `f32`, in this order).
pub fn fold_standardisation(mean: f32, std: f32, scale: f32, zero_point: i8) -> (f32, f32) {
    let mul = 1.0 / (std * scale);
    let add = f32::from(zero_point) - mean * mul;
    (mul, add)
}

/// Symmetric int8 weight: `clamp(roundf(w / scale), -127, 127)`; 0 for a non-positive or NaN scale.
pub fn quantize_weight(w: f32, scale: f32) -> i8 {
    if scale.is_nan() || scale <= 0.0 {
        return 0;
    }
    let q = libm::roundf(w / scale);
    if q.is_nan() {
        0
    } else {
        q.clamp(-127.0, 127.0) as i8
    }
}

/// Int32 bias in the accumulator scale `input_scale * weight_scale`: `roundf(b / scale)`, saturated.
pub fn quantize_bias(b: f32, accumulator_scale: f32) -> i32 {
    if accumulator_scale.is_nan() || accumulator_scale <= 0.0 {
        return 0;
    }
    let q = libm::roundf(b / accumulator_scale);
    if q.is_nan() {
        0
    } else {
        // `as` saturates for out-of-range floats.
        q as i32
    }
}

/// Per-channel symmetric weight scale `max_abs / 127`; 1.0 for an all-zero (or non-finite) channel.
pub fn symmetric_scale(max_abs: f32) -> f32 {
    if max_abs.is_finite() && max_abs > 0.0 {
        max_abs / 127.0
    } else {
        1.0
    }
}

/// Asymmetric int8 parameters `(scale, zero_point)` covering `[min, max]` (widened to contain 0, so
/// real 0 is exactly representable): `scale = (hi - lo) / 255`,
/// `zero_point = clamp(roundf(-128 - lo / scale), -128, 127)`. A degenerate range gives `(1.0, 0)`.
pub fn asymmetric_params(min: f32, max: f32) -> (f32, i8) {
    let lo = if min.is_finite() { min.min(0.0) } else { 0.0 };
    let hi = if max.is_finite() { max.max(0.0) } else { 0.0 };
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return (1.0, 0);
    }
    let scale = span / 255.0;
    let zp = libm::roundf(-128.0 - lo / scale).clamp(-128.0, 127.0) as i8;
    (scale, zp)
}

/// Real value of an asymmetric int8 code: `scale * (q - zero_point)`.
pub fn dequantize(q: i8, scale: f32, zero_point: i8) -> f32 {
    scale * (i32::from(q) - i32::from(zero_point)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact reference: round half away from zero of acc * m / 2^(31+shift), computed in i128.
    fn reference(acc: i32, m: i32, shift: i8) -> i32 {
        let p = i128::from(acc) * i128::from(m);
        let total = 31 + i32::from(shift);
        let r = if total >= 0 {
            let d = 1i128 << total;
            let mag = p.abs();
            let q = (2 * mag + d) / (2 * d);
            if p < 0 {
                -q
            } else {
                q
            }
        } else {
            p.checked_mul(1i128 << (-total))
                .unwrap_or(if p < 0 { i128::MIN } else { i128::MAX })
        };
        r.clamp(i128::from(i32::MIN), i128::from(i32::MAX)) as i32
    }

    #[test]
    fn requantize_ties_round_away_from_zero() {
        // M = 0.5: multiplier 2^30, shift 0.
        let (m, s) = quantize_multiplier(0.5);
        assert_eq!((m, s), (1 << 30, 0));
        assert_eq!(requantize(5, m, s), 3); // 2.5 -> 3
        assert_eq!(requantize(-5, m, s), -3); // -2.5 -> -3
        assert_eq!(requantize(3, m, s), 2); // 1.5 -> 2
        assert_eq!(requantize(-3, m, s), -2);
        assert_eq!(requantize(1, m, s), 1); // 0.5 -> 1
        assert_eq!(requantize(-1, m, s), -1);
        assert_eq!(requantize(4, m, s), 2);
        assert_eq!(requantize(0, m, s), 0);
        // M = 0.25 (multiplier 2^30, shift 1): 0.25*6 = 1.5 -> 2, 0.25*5 = 1.25 -> 1, 0.25*7=1.75 -> 2.
        let (m, s) = quantize_multiplier(0.25);
        assert_eq!(requantize(6, m, s), 2);
        assert_eq!(requantize(5, m, s), 1);
        assert_eq!(requantize(7, m, s), 2);
        assert_eq!(requantize(-6, m, s), -2);
        assert_eq!(requantize(-7, m, s), -2);
    }

    #[test]
    fn requantize_saturates() {
        let (m, s) = quantize_multiplier(3.0);
        assert_eq!(requantize(i32::MAX, m, s), i32::MAX);
        assert_eq!(requantize(i32::MIN, m, s), i32::MIN);
        assert_eq!(requantize(1_000_000_000, m, s), i32::MAX);
        assert_eq!(requantize(-1_000_000_000, m, s), i32::MIN);
        // Extreme shifts never panic.
        assert_eq!(requantize(1, MULTIPLIER_MIN, SHIFT_MIN), i32::MAX);
        assert_eq!(requantize(-1, MULTIPLIER_MIN, SHIFT_MIN), i32::MIN);
        assert_eq!(requantize(i32::MAX, i32::MAX, SHIFT_MAX), 0);
        assert_eq!(requantize(i32::MIN, i32::MIN, i8::MAX), 0);
        assert_eq!(requantize(i32::MIN, i32::MIN, i8::MIN), i32::MAX);
        assert_eq!(requantize(0, i32::MAX, i8::MIN), 0);
    }

    #[test]
    fn requantize_matches_exact_reference() {
        // Deterministic LCG sweep over accumulators, multipliers and shifts.
        let mut state: u64 = 0x1234_5678_9abc_def0;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 32) as u32
        };
        for _ in 0..200_000 {
            let acc = next() as i32 >> (next() % 31);
            let m = (MULTIPLIER_MIN as u32 + (next() >> 2)) as i32;
            let shift = (next() % 80) as i32 - 40;
            let shift = shift as i8;
            assert_eq!(
                requantize(acc, m, shift),
                reference(acc, m, shift),
                "{acc} {m} {shift}"
            );
        }
    }

    #[test]
    fn quantize_multiplier_round_trips_exactly() {
        let mut state: u32 = 12345;
        for _ in 0..100_000 {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let bits = 0x2000_0000 + (state % 0x2000_0000); // f32 in about [1e-19, 2]... positive
            let real = f32::from_bits(bits);
            let (m, s) = quantize_multiplier(real);
            if real < libm::exp2f(-33.0) {
                assert_eq!((m, s), (0, 0));
                continue;
            }
            assert!(is_valid_multiplier(m, s), "{real} -> {m} {s}");
            assert_eq!(multiplier_to_real(m, s), f64::from(real), "{real}");
        }
        for real in [1.0f32, 0.999_999_94, 1.5e-5, 0.003_921_568_6, 7.25, 2.0e9] {
            let (m, s) = quantize_multiplier(real);
            assert!(is_valid_multiplier(m, s));
            assert_eq!(multiplier_to_real(m, s), f64::from(real));
        }
        assert_eq!(quantize_multiplier(0.0), (0, 0));
        assert_eq!(quantize_multiplier(-1.0), (0, 0));
        assert_eq!(quantize_multiplier(f32::NAN), (0, 0));
        assert_eq!(quantize_multiplier(f32::INFINITY), (0, 0));
        assert_eq!(quantize_multiplier(1e-12), (0, 0));
        assert_eq!(quantize_multiplier(1e12), (MULTIPLIER_MIN, SHIFT_MIN));
    }

    #[test]
    fn requantize_approximates_real_product() {
        for real in [0.001f32, 0.0173, 0.5, 0.77, 1.0, 3.3] {
            let (m, s) = quantize_multiplier(real);
            for acc in [-100_000, -777, -1, 0, 1, 13, 4096, 99_999] {
                let exact = f64::from(acc) * f64::from(real);
                let got = requantize(acc, m, s);
                assert!(
                    (f64::from(got) - exact).abs() <= 0.5 + 1e-9,
                    "{acc}*{real}: {got}"
                );
            }
        }
    }

    #[test]
    fn input_quantisation() {
        let (mul, add) = fold_standardisation(10.0, 2.0, 0.05, -3);
        // z = (x - 10) / 2, q = z / 0.05 - 3
        assert_eq!(quantize_input(10.0, mul, add, -3), -3);
        assert_eq!(quantize_input(11.0, mul, add, -3), 7);
        assert_eq!(quantize_input(9.0, mul, add, -3), -13);
        assert_eq!(quantize_input(1e9, mul, add, -3), 127);
        assert_eq!(quantize_input(-1e9, mul, add, -3), -128);
        assert_eq!(quantize_input(f32::INFINITY, mul, add, -3), 127);
        assert_eq!(quantize_input(f32::NEG_INFINITY, mul, add, -3), -128);
        assert_eq!(quantize_input(f32::NAN, mul, add, -3), -3);
        // Ties round away from zero: 0.5 -> 1, -0.5 -> -1.
        assert_eq!(quantize_input(0.5, 1.0, 0.0, 0), 1);
        assert_eq!(quantize_input(-0.5, 1.0, 0.0, 0), -1);
        assert_eq!(quantize_input(2.5, 1.0, 0.0, 0), 3);
    }

    #[test]
    fn input_quantisation_is_roundf_then_clamp() {
        let check = |v: f32| {
            if !v.is_nan() {
                let reference = libm::roundf(v).clamp(-128.0, 127.0) as i8;
                assert_eq!(quantize_input(v, 1.0, 0.0, 7), reference, "{v:e}");
            }
        };
        // Integers and half-integers (ties) in [-300, 300] and their 3 nearest neighbours per side.
        for k in -600i32..=600 {
            let centre = k as f32 * 0.5;
            check(centre);
            let (mut up, mut down) = (centre, centre);
            for _ in 0..3 {
                up = libm::nextafterf(up, f32::INFINITY);
                down = libm::nextafterf(down, f32::NEG_INFINITY);
                check(up);
                check(down);
            }
        }
        // A stride over all bit patterns: huge, tiny, subnormal, infinite values.
        for bits in (0..=u32::MAX).step_by(4099) {
            check(f32::from_bits(bits));
        }
        check(f32::INFINITY);
        check(f32::NEG_INFINITY);
    }

    #[test]
    fn weights_biases_and_activation_params() {
        assert_eq!(quantize_weight(1.0, 1.0 / 127.0), 127);
        assert_eq!(quantize_weight(-2.0, 1.0 / 127.0), -127);
        assert_eq!(quantize_weight(0.5, 0.0), 0);
        assert_eq!(quantize_bias(1e30, 1e-6), i32::MAX);
        assert_eq!(quantize_bias(-2.5, 1.0), -3);
        assert_eq!(symmetric_scale(0.0), 1.0);
        let (scale, zp) = asymmetric_params(-1.0, 3.0);
        assert!((scale - 4.0 / 255.0).abs() < 1e-9);
        assert_eq!(zp, -64); // -128 + 1/scale = -128 + 63.75 -> -64.25 -> -64
        assert!(dequantize(zp, scale, zp).abs() < 1e-9);
        let (scale, zp) = asymmetric_params(0.0, 6.0);
        assert_eq!(zp, -128);
        assert!((dequantize(127, scale, zp) - 6.0).abs() < 1e-5);
        assert_eq!(asymmetric_params(0.0, 0.0), (1.0, 0));
        assert_eq!(requantize_to_i8(-1000, 1 << 30, 0, 5, true), 5);
        assert_eq!(requantize_to_i8(-1000, 1 << 30, 0, 5, false), -128);
        assert_eq!(requantize_to_i8(1000, 1 << 30, 0, 5, false), 127);
        assert_eq!(requantize_to_i8(20, 1 << 30, 0, 5, true), 15);
    }
}
