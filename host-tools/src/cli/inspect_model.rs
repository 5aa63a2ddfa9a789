//! `riskctl inspect-model`: describe a model blob and check its integrity.
use std::path::PathBuf;

use anyhow::Context;

/// Print a model blob's header, sizes and parameter summary, and check its integrity (magic,
/// version, kind, feature schema, payload length, CRC-32, and the model's own validation).
/// Exits with an error naming the problem when any check fails.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model blob (`*.rsk`).
    pub file: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let blob = std::fs::read(&args.file)
        .with_context(|| format!("{}: cannot read", args.file.display()))?;
    // A training checkpoint (JSON) is not a blob: say what it is and how to get the blob.
    let json = blob.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&blob);
    if json.trim_ascii_start().starts_with(b"{")
        && riskscore_train::export::Checkpoint::load(&args.file).is_ok()
    {
        anyhow::bail!(
            "{}: not a model blob: it is a training checkpoint (the JSON `riskctl train` writes); \
             export it first: riskctl export-model {} --out MODEL.rsk",
            args.file.display(),
            args.file.display()
        );
    }
    let text = riskscore_train::export::inspect(&blob)
        .map_err(|e| anyhow::anyhow!("{}: integrity check failed: {e}", args.file.display()))?;
    outln!("{}", args.file.display());
    out!("{text}");
    Ok(())
}
