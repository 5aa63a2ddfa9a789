//! The int8 kernels: centred activations packed two per word, paired-row dot products and the
//! requantisation fast path, bit for bit the arithmetic of [`crate::quant`].
use crate::quant;

/// Two centred activations (each in `[-32768, 32767]`) in one word: `a` in the low half, `b` in the
/// high half, each as 16-bit two's complement.
pub(super) fn pack(a: i32, b: i32) -> u32 {
    (a as u32 & 0xffff) | ((b as u32) << 16)
}

/// The low half of a [`pack`]ed word, sign-extended (the M4 multiplies it in place: `SMLABB`).
#[inline(always)]
fn low(word: u32) -> i32 {
    ((word as i32) << 16) >> 16
}

/// The high half of a [`pack`]ed word, sign-extended (`SMLABT`).
#[inline(always)]
fn high(word: u32) -> i32 {
    (word as i32) >> 16
}

/// Four products: the bytes of `w` (little-endian `i8` weights, sign-extended by shifts) with the
/// activations packed in `x01`, `x23`.
#[inline(always)]
fn dot4(w: i32, x01: u32, x23: u32) -> i32 {
    ((w << 24) >> 24) * low(x01)
        + ((w << 16) >> 24) * high(x01)
        + ((w << 8) >> 24) * low(x23)
        + (w >> 24) * high(x23)
}

/// One layer's input activations as [`dot2`] consumes them: the [`pack`]ed words in steps of
/// four activations, then the (at most 3) activations left over, unpacked.
pub(super) struct PackedInput<'a> {
    steps: &'a [[u32; 2]],
    tail: [i32; 3],
}

impl<'a> PackedInput<'a> {
    /// `words` holds `width` packed activations (`width.div_ceil(2)` words).
    pub(super) fn new(words: &'a [u32], width: usize) -> Self {
        let (steps, rest) = words
            .split_at_checked(width / 4 * 2)
            .unwrap_or((words, &[]));
        let x01 = rest.first().copied().unwrap_or(0);
        let x23 = rest.get(1).copied().unwrap_or(0);
        Self {
            steps: steps.as_chunks::<2>().0,
            tail: [low(x01), high(x01), low(x23)],
        }
    }
}

/// The dot products of two weight rows (`i8`, as stored, `width` each) with the input; four
/// weights per row and step (one word load each).
///
/// `|w| <= 128`, `|x| <= 255` and at most [`super::MAX_WIDTH`] terms: `|sum| < 2^22`, no overflow.
#[inline(always)]
pub(super) fn dot2(row_a: &[u8], row_b: &[u8], input: &PackedInput<'_>) -> (i32, i32) {
    let (a4, a_rest) = row_a.as_chunks::<4>();
    let (b4, b_rest) = row_b.as_chunks::<4>();
    let (mut sum_a, mut sum_b) = (0i32, 0i32);
    for ((wa, wb), &[x01, x23]) in a4.iter().zip(b4).zip(input.steps) {
        sum_a += dot4(i32::from_le_bytes(*wa), x01, x23);
        sum_b += dot4(i32::from_le_bytes(*wb), x01, x23);
    }
    for ((&wa, &wb), &x) in a_rest.iter().zip(b_rest).zip(&input.tail) {
        sum_a += i32::from(wa as i8) * x;
        sum_b += i32::from(wb as i8) * x;
    }
    (sum_a, sum_b)
}

/// `quant::requantize_to_i8(acc, multiplier, shift, zero_point, relu) - zero_point`, with a fast
/// path for the pairs a trained model holds.
///
/// Fast path (`multiplier >= 0` and `t = 31 + shift` in `33..=63`, i.e. a real multiplier below
/// 1/2): the half-away-from-zero rounding of `|acc| * multiplier / 2^t` is
/// `((magnitude >> (t - 1)) + 1) >> 1`, and as `t - 1 >= 32` the shift only sees the high word of
/// the 64-bit product (< 2^30, so nothing below overflows). Clamping the signed result to the
/// centred output range `bounds = (relu ? 0 : -128 - zp, 127 - zp)` equals the definition's
/// `clamp(saturate_i32(r) + zp, low, 127) - zp`: any result the `i32` saturation would touch is far
/// outside the `i8` range anyway.
/// Every other pair takes the definition itself.
#[inline(always)]
pub(super) fn requantize_centred(
    acc: i32,
    multiplier: i32,
    shift: i8,
    zero_point: i8,
    relu: bool,
    bounds: (i32, i32),
) -> i16 {
    let high_shift = i32::from(shift) - 2; // t - 33
    if multiplier >= 0 && (0..=30).contains(&high_shift) {
        let product = u64::from(acc.unsigned_abs()) * u64::from(multiplier.unsigned_abs());
        let high = (product >> 32) as u32;
        let halves = (high >> high_shift.unsigned_abs()) as i32; // < 2^30: no overflow below
        let rounded = (halves + 1) >> 1;
        let signed = if acc < 0 { -rounded } else { rounded };
        return signed.max(bounds.0).min(bounds.1) as i16;
    }
    let q = quant::requantize_to_i8(acc, multiplier, shift, zero_point, relu);
    i16::from(q) - i16::from(zero_point)
}

#[cfg(test)]
// The reference is written with plain indices on purpose: it is the definition, not the kernel.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::{
        bound, Outputs, QuantLayer, QuantMlp, MAX_INPUTS, MAX_LAYERS, MAX_OUTPUTS, MAX_WIDTH,
    };
    use super::*;
    use crate::bounded::BoundedVec;
    use crate::features::{Features, FEATURE_COUNT};

    #[test]
    fn centred_requantisation_matches_the_definition() {
        let accs = [
            i32::MIN,
            i32::MIN + 1,
            -1 << 30,
            -4_000_001,
            -65_536,
            -1_000,
            -3,
            -1,
            0,
            1,
            2,
            777,
            65_535,
            4_000_000,
            1 << 30,
            i32::MAX,
        ];
        let multipliers = [i32::MIN, -5, 0, 1, 1 << 30, (1 << 30) + 12_345, i32::MAX];
        let mut checked = 0u32;
        for shift in -40i8..=40 {
            for &m in &multipliers {
                for &zp in &[-128i8, -100, -1, 0, 5, 127] {
                    for relu in [false, true] {
                        let zp32 = i32::from(zp);
                        let bounds = (if relu { 0 } else { -128 - zp32 }, 127 - zp32);
                        let mut check = |acc: i32| {
                            let want = i16::from(quant::requantize_to_i8(acc, m, shift, zp, relu))
                                - i16::from(zp);
                            let got = requantize_centred(acc, m, shift, zp, relu, bounds);
                            assert_eq!(got, want, "acc {acc} m {m} shift {shift} zp {zp} {relu}");
                            checked += 1;
                        };
                        for &acc in &accs {
                            check(acc);
                        }
                        // Around every rounding tie of this (m, shift) near the clip at 256.
                        if m > 0 && (2..=32).contains(&shift) {
                            let t = 31 + u32::from(shift.unsigned_abs());
                            for k in [1i128, 3, 255, 511, 513] {
                                let tie = (k << (t - 1)) / i128::from(m);
                                for d in -2..=2 {
                                    if let Ok(acc) = i32::try_from(tie + d) {
                                        check(acc);
                                        check(acc.saturating_neg());
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 50_000);
    }

    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
        fn i32(&mut self) -> i32 {
            self.next() as i32
        }
    }

    /// The int8 forward pass written as plainly as its definition (module docs).
    fn reference_forward(m: &QuantMlp<'_>, features: &Features) -> Outputs {
        let mut act = m.quantize_inputs(features);
        let mut zp = i32::from(m.input_zero_point);
        let mut width = m.inputs.len();
        let mut y = [0.0f32; MAX_OUTPUTS];
        let word = |b: &[u8], j: usize| i32::from_le_bytes(b[4 * j..4 * j + 4].try_into().unwrap());
        for (l, layer) in m.layers.iter().enumerate() {
            let out = usize::from(layer.out_dim);
            let mut next = [0i8; MAX_WIDTH];
            for j in 0..out {
                let mut acc = 0i32;
                for i in 0..width {
                    acc += i32::from(layer.weights[j * width + i] as i8) * (i32::from(act[i]) - zp);
                }
                let acc = acc.saturating_add(word(layer.bias, j));
                if l + 1 == m.layers.len() {
                    let mut v = acc as f32 * m.output_scales[j];
                    if layer.relu && v < 0.0 {
                        v = 0.0;
                    }
                    y[j] = bound(v);
                } else {
                    next[j] = quant::requantize_to_i8(
                        acc,
                        word(layer.multipliers, j),
                        layer.shifts[j] as i8,
                        layer.output_zero_point,
                        layer.relu,
                    );
                }
            }
            act = next;
            zp = i32::from(layer.output_zero_point);
            width = out;
        }
        y
    }

    #[test]
    fn int8_forward_matches_the_plain_definition_for_any_shape() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut weights = [[0u8; MAX_WIDTH * MAX_WIDTH]; MAX_LAYERS];
        let mut biases = [[0u8; 4 * MAX_WIDTH]; MAX_LAYERS];
        let mut multipliers = [[0u8; 4 * MAX_WIDTH]; MAX_LAYERS];
        let mut shifts = [[0u8; MAX_WIDTH]; MAX_LAYERS];
        for case in 0..400 {
            let n_inputs = 1 + rng.below(MAX_INPUTS);
            let n_layers = 1 + rng.below(MAX_LAYERS);
            let mut dims = [0usize; MAX_LAYERS];
            for (l, d) in dims.iter_mut().enumerate().take(n_layers) {
                *d = if l + 1 == n_layers {
                    1 + rng.below(MAX_OUTPUTS)
                } else if case % 2 == 0 {
                    1 + rng.below(MAX_WIDTH)
                } else {
                    1 + rng.below(9)
                };
            }
            let mut inputs = [0u8; MAX_INPUTS];
            let mut input_mul = [0f32; MAX_INPUTS];
            let mut input_add = [0f32; MAX_INPUTS];
            for k in 0..n_inputs {
                inputs[k] = rng.below(FEATURE_COUNT) as u8;
                input_mul[k] = 0.01 + rng.below(1000) as f32 * 0.1;
                input_add[k] = rng.below(200) as f32 - 100.0;
            }
            let mut in_dim = n_inputs;
            let mut layers = BoundedVec::<QuantLayer<'_>, MAX_LAYERS>::new();
            for l in 0..n_layers {
                let out = dims[l];
                for b in weights[l].iter_mut().take(out * in_dim) {
                    *b = rng.next() as u8;
                }
                for j in 0..out {
                    let bias = match rng.below(8) {
                        0 => i32::MAX - rng.below(100) as i32,
                        1 => i32::MIN + rng.below(100) as i32,
                        _ => rng.i32() >> (8 + rng.below(20)),
                    };
                    biases[l][4 * j..4 * j + 4].copy_from_slice(&bias.to_le_bytes());
                    let (m, s) = match rng.below(10) {
                        0 => (rng.i32(), rng.i32() as i8),
                        1 => (rng.i32(), -32 + rng.below(4) as i8),
                        _ => (
                            quant::MULTIPLIER_MIN + rng.below(1 << 30) as i32,
                            rng.below(40) as i8 - 4,
                        ),
                    };
                    multipliers[l][4 * j..4 * j + 4].copy_from_slice(&m.to_le_bytes());
                    shifts[l][j] = s as u8;
                }
                in_dim = out;
            }
            for l in 0..n_layers {
                let in_dim = if l == 0 { n_inputs } else { dims[l - 1] };
                let out = dims[l];
                let last = l + 1 == n_layers;
                let layer = QuantLayer {
                    out_dim: out as u16,
                    relu: rng.below(2) == 0,
                    weights: &weights[l][..out * in_dim],
                    bias: &biases[l][..4 * out],
                    multipliers: if last {
                        &[]
                    } else {
                        &multipliers[l][..4 * out]
                    },
                    shifts: if last { &[] } else { &shifts[l][..out] },
                    output_zero_point: if last { 0 } else { rng.next() as i8 },
                };
                assert!(layers.push(layer).is_ok());
            }
            let scales = [0.001f32, 0.5];
            let mlp = QuantMlp {
                inputs: BoundedVec::from_slice(&inputs[..n_inputs]).unwrap(),
                input_mul: BoundedVec::from_slice(&input_mul[..n_inputs]).unwrap(),
                input_add: BoundedVec::from_slice(&input_add[..n_inputs]).unwrap(),
                input_zero_point: rng.next() as i8,
                layers,
                output_scales: BoundedVec::from_slice(&scales[..dims[n_layers - 1]]).unwrap(),
            };
            for _ in 0..20 {
                let mut features = [0f32; FEATURE_COUNT];
                for f in features.iter_mut() {
                    *f = match rng.below(20) {
                        0 => f32::NAN,
                        1 => f32::INFINITY,
                        _ => (rng.below(4000) as f32 - 2000.0) * 0.05,
                    };
                }
                let (got, want) = (mlp.forward(&features), reference_forward(&mlp, &features));
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "case {case}");
            }
        }
    }
}
