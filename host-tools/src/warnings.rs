//! Showing the warnings the library crates return instead of printing (a fold whose DRL got no
//! kinematic fallback, ...): one line each on stderr, after the stage that produced them.

/// Print each warning as `riskctl: warning: <text>` on stderr.
pub fn print<'a>(warnings: impl IntoIterator<Item = &'a String>) {
    for warning in warnings {
        eprintln!("riskctl: warning: {warning}");
    }
}
