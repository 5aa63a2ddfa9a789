//! Flag expressions: a flag field (`valid`, `new_track`, `heading_valid`) computed from several
//! signals of one message, e.g. `valid = "VALID and not NEW_TRACK"` or
//! `valid = "VALID and LONG_DIST < 255"`.
//!
//! Grammar: `TERM (and TERM)*`; `TERM` is `SIGNAL` (true when non-zero), `not SIGNAL` (true when
//! zero) or `SIGNAL OP NUMBER` with `OP` one of `==`, `!=`, `<`, `<=`, `>`, `>=`. Values are the
//! DBC's physical values (before the field's `factor`/`offset`), read without the DBC range check
//! (radars mark empty slots with out-of-range sentinels); a non-finite value is a decode error.

/// A comparison of one signal's value with a constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cmp {
    NonZero,
    Zero,
    Eq(f64),
    Ne(f64),
    Lt(f64),
    Le(f64),
    Gt(f64),
    Ge(f64),
}

impl Cmp {
    pub fn holds(self, v: f64) -> bool {
        match self {
            Self::NonZero => v != 0.0,
            Self::Zero => v == 0.0,
            Self::Eq(c) => v == c,
            Self::Ne(c) => v != c,
            Self::Lt(c) => v < c,
            Self::Le(c) => v <= c,
            Self::Gt(c) => v > c,
            Self::Ge(c) => v >= c,
        }
    }
}

/// A parsed term: the signal's name and its comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    pub signal: String,
    pub cmp: Cmp,
}

/// Parses an expression; the error says what is wrong where.
pub fn parse(text: &str) -> Result<Vec<Term>, String> {
    let words: Vec<&str> = text.split_whitespace().collect();
    if words.is_empty() {
        return Err("empty expression".into());
    }
    let mut terms = Vec::new();
    for part in words.split(|w| *w == "and") {
        let term = match part {
            [] => return Err(format!("`and` without a term on both sides in `{text}`")),
            ["not", name] => Term {
                signal: signal_name(name, text)?,
                cmp: Cmp::Zero,
            },
            [name] => Term {
                signal: signal_name(name, text)?,
                cmp: Cmp::NonZero,
            },
            [name, op, number] => {
                let c: f64 = number
                    .parse()
                    .ok()
                    .filter(|c: &f64| c.is_finite())
                    .ok_or_else(|| format!("`{number}` is not a finite number in `{text}`"))?;
                let cmp = match *op {
                    "==" => Cmp::Eq(c),
                    "!=" => Cmp::Ne(c),
                    "<" => Cmp::Lt(c),
                    "<=" => Cmp::Le(c),
                    ">" => Cmp::Gt(c),
                    ">=" => Cmp::Ge(c),
                    _ => {
                        return Err(format!(
                            "unknown operator `{op}` in `{text}` (==, !=, <, <=, >, >=)"
                        ))
                    }
                };
                Term {
                    signal: signal_name(name, text)?,
                    cmp,
                }
            }
            _ => {
                return Err(format!(
                    "cannot read `{}` in `{text}`: a term is `SIGNAL`, `not SIGNAL` or `SIGNAL OP NUMBER` (spaces around the operator), terms joined by `and`",
                    part.join(" ")
                ))
            }
        };
        terms.push(term);
    }
    Ok(terms)
}

fn signal_name(word: &str, text: &str) -> Result<String, String> {
    let ok = word.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !word.starts_with(|c: char| c.is_ascii_digit());
    if ok && word != "not" && word != "or" {
        Ok(word.to_string())
    } else {
        Err(format!("`{word}` is not a signal name in `{text}`"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_terms_and_refuses_what_it_cannot_mean() {
        let t = parse("VALID and not NEW_TRACK and LONG_DIST < 255").unwrap();
        assert_eq!(
            t,
            [
                Term {
                    signal: "VALID".into(),
                    cmp: Cmp::NonZero
                },
                Term {
                    signal: "NEW_TRACK".into(),
                    cmp: Cmp::Zero
                },
                Term {
                    signal: "LONG_DIST".into(),
                    cmp: Cmp::Lt(255.0)
                },
            ]
        );
        assert!(Cmp::Lt(255.0).holds(254.9) && !Cmp::Lt(255.0).holds(255.0));
        assert!(Cmp::Ge(2.0).holds(2.0) && Cmp::Ne(1.0).holds(0.0));
        for bad in [
            "",
            "VALID and",
            "VALID or NEW_TRACK",
            "VALID ~ 1",
            "LONG_DIST < x",
            "LONG_DIST<255",
            "1X",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }
}
