//! host-tools: the `riskctl` command line (`src/main.rs`, one module per subcommand in `src/cli/`)
//! and the end-to-end main job it runs, [`demo`]. The work itself lives in the library crates
//! beside this one: `riskscore-data` (event folders, simulator, import, CSV scoring, CAN export),
//! `riskscore-eval` (warning protocol, metrics, reports, plots) and `riskscore-train` (comparisons,
//! training, GSSM, quantisation, export, transfer benchmark).

/// `print!` through [`print_out`]: a reader that closed standard output ends the printing, not
/// the run (`riskctl evaluate ... | head`). Exported: `riskctl`'s subcommands print with it too.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::print_out(format_args!($($arg)*))
    };
}

/// `println!` through [`print_out`] (see [`out!`]).
#[macro_export]
macro_rules! outln {
    () => {
        $crate::print_out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::print_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub mod demo;
pub mod warnings;

/// An error and its causes joined by `: `, each said once: many library errors already quote
/// their source in their own message, and `{:#}` would print it a second time. What `riskctl`
/// prints after `error:`.
pub fn error_text<'a>(
    causes: impl IntoIterator<Item = &'a (dyn std::error::Error + 'static)>,
) -> String {
    let mut text = String::new();
    for cause in causes {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

/// Writes to standard output. Unlike `print!`, which panics (exit 101 and a backtrace) when the
/// reader has gone (`riskctl demo | head -1`), a closed standard output is ignored: the run goes
/// on and still writes its files and its exit status; any other write error is a warning on
/// stderr. What `riskctl`'s subcommands and the demo print their results with.
pub fn print_out(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    if let Err(e) = std::io::stdout().lock().write_fmt(args) {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("riskctl: warning: cannot write to standard output: {e}");
        }
    }
}
