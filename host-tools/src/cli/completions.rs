//! `riskctl completions` and `riskctl man`: shell completion scripts and man pages, generated from
//! the same clap definitions as `--help`.
use std::path::PathBuf;

use anyhow::Context;

/// What `--help` says after the options (a doc comment of [`Args`] is not shown: the
/// subcommand's one-line description in `main.rs` takes its place).
const ABOUT_COMPLETIONS: &str = "\
Install, for example:
  riskctl completions bash > ~/.local/share/bash-completion/completions/riskctl
  riskctl completions zsh  > ~/.zfunc/_riskctl        (with fpath+=~/.zfunc)
  riskctl completions fish > ~/.config/fish/completions/riskctl.fish";

/// Print a completion script for SHELL to standard output.
///
/// The rest: [`ABOUT_COMPLETIONS`].
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_COMPLETIONS)]
pub struct Args {
    /// The shell to complete for.
    pub shell: clap_complete::Shell,
}

/// Write `riskctl.1` and `riskctl-<subcommand>.1` into DIR (created if missing); read one with
/// `man -l DIR/riskctl.1`, or put DIR on MANPATH.
#[derive(clap::Args, Debug)]
pub struct ManArgs {
    /// Folder for the man pages.
    #[arg(long, value_name = "DIR")]
    pub out_dir: PathBuf,
}

pub fn run(args: Args, mut command: clap::Command) -> anyhow::Result<()> {
    use std::io::Write as _;
    // Generated into memory first: clap_complete panics when its writer fails, and a reader that
    // closes the pipe early (`| head`) is normal for a filter.
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "riskctl", &mut script);
    match std::io::stdout().write_all(&script) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

pub fn man(args: ManArgs, command: clap::Command) -> anyhow::Result<()> {
    // Built complete beside the folder, then swapped in whole (riskscore-output).
    let dir = riskscore_output::OutputDir::create(&args.out_dir)?;
    clap_mangen::generate_to(command, dir.path())
        .with_context(|| format!("{}: cannot write the man pages", args.out_dir.display()))?;
    dir.commit()?;
    outln!("man pages written to {}", args.out_dir.display());
    Ok(())
}
