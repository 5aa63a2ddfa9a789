//! One colour and line style per method, the same in every figure (`riskctl demo`, `evaluate --out`,
//! `plot`): a reader who learned "DRL is blue" in one figure can trust it in the next, and a
//! method's colour does not depend on its row position.
//!
//! The eight methods of the paper have fixed styles ([`CANONICAL`]); any other row name (a
//! `NAME=FILE` model, `DRL-f32`, two files of one kind named by their stems) is an extra and takes
//! the next unused extra style in order of first appearance. Extras alternate a wide solid and a
//! narrow dashed line, so two identical models drawn on top of each other stay both visible.
//! Plain data (no plotters), so the palette is tested without the `plots` feature.

/// How a line is stroked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineStyle {
    Solid,
    Dashed,
}

/// A method's colour (8-bit RGB), stroke and width in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MethodStyle {
    pub rgb: (u8, u8, u8),
    pub line: LineStyle,
    pub width: u32,
}

const fn solid(rgb: (u8, u8, u8)) -> MethodStyle {
    MethodStyle {
        rgb,
        line: LineStyle::Solid,
        width: 2,
    }
}

const fn dashed(rgb: (u8, u8, u8)) -> MethodStyle {
    MethodStyle {
        rgb,
        line: LineStyle::Dashed,
        width: 2,
    }
}

/// The fixed styles: learned scores solid, surrogate baselines dashed; colours from the
/// colour-blind-safe Okabe-Ito set (EI's yellow darkened to stay readable on white).
pub const CANONICAL: [(&str, MethodStyle); 9] = [
    ("DRL", solid((0, 114, 178))),
    ("MSRA", solid((213, 94, 0))),
    ("SSRA", solid((0, 158, 115))),
    ("GSSM", solid((204, 121, 167))),
    ("MSRA-GSSM", solid((230, 159, 0))),
    ("TTC2D", dashed((86, 180, 233))),
    ("TAdv", dashed((0, 0, 0))),
    ("EI", dashed((170, 150, 0))),
    ("TAdv-corridor", dashed((100, 100, 100))),
];

/// Colours of the extras, distinct from the canonical ones, reused cyclically.
const EXTRA_COLOURS: [(u8, u8, u8); 6] = [
    (120, 120, 120),
    (110, 60, 160),
    (150, 80, 40),
    (20, 90, 90),
    (200, 40, 60),
    (90, 130, 30),
];

/// Assigns styles: canonical names their fixed style, extras the next extra style.
#[derive(Clone, Debug, Default)]
pub struct Palette {
    extras: Vec<String>,
}

impl Palette {
    pub fn new() -> Self {
        Self::default()
    }

    /// A palette that has already seen `names` in this order (so extras are numbered the same way
    /// in every figure built from one method list).
    pub fn for_methods<'a>(names: impl IntoIterator<Item = &'a str>) -> Self {
        let mut palette = Self::new();
        for name in names {
            palette.style(name);
        }
        palette
    }

    /// The style of `name`; an extra seen for the first time takes the next extra style.
    pub fn style(&mut self, name: &str) -> MethodStyle {
        if let Some((_, style)) = CANONICAL.iter().find(|(n, _)| *n == name) {
            return *style;
        }
        let index = match self.extras.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.extras.push(name.to_owned());
                self.extras.len() - 1
            }
        };
        extra_style(index)
    }
}

/// The `index`-th extra style: colours cycle; wide solid and narrow dashed alternate.
fn extra_style(index: usize) -> MethodStyle {
    let rgb = EXTRA_COLOURS[index % EXTRA_COLOURS.len()];
    if index.is_multiple_of(2) {
        MethodStyle {
            rgb,
            line: LineStyle::Solid,
            width: 4,
        }
    } else {
        dashed(rgb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_canonical_method_keeps_its_style_whatever_its_position() {
        let alone = Palette::new().style("MSRA");
        let mut after_others = Palette::for_methods(["x", "DRL", "y", "EI"]);
        assert_eq!(after_others.style("MSRA"), alone);
        assert_eq!(alone.rgb, (213, 94, 0));
        assert_eq!(Palette::new().style("TAdv").line, LineStyle::Dashed);
    }

    #[test]
    fn every_method_and_early_extras_are_distinguishable() {
        let mut palette = Palette::new();
        let names = [
            "DRL",
            "MSRA",
            "SSRA",
            "GSSM",
            "MSRA-GSSM",
            "TTC2D",
            "TAdv",
            "EI",
            "TAdv-corridor",
            "a",
            "b",
            "c",
            "d",
            "e",
            "f",
        ];
        let styles: Vec<MethodStyle> = names.iter().map(|n| palette.style(n)).collect();
        for (i, a) in styles.iter().enumerate() {
            for b in &styles[i + 1..] {
                assert_ne!(a.rgb, b.rgb, "{a:?} and {b:?} share a colour");
            }
        }
    }

    #[test]
    fn two_identical_models_draw_differently_and_stably() {
        let mut palette = Palette::new();
        let first = palette.style("drl-a");
        let second = palette.style("drl-b");
        assert_ne!(first.line, second.line, "overlapping lines must both show");
        assert!(first.width > second.width);
        // Asking again (another figure of the same run) gives the same styles.
        assert_eq!(palette.style("drl-a"), first);
        assert_eq!(palette.style("drl-b"), second);
    }
}
