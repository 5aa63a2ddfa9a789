//! What already stands where an output goes: standard output under another name. Both tools
//! (`riskctl`, `can-bridge`) ask here, so every name of standard output is told apart the same way.
use std::path::Path;

/// True when the output `path` is this process's standard output: `-`, or a path to the same
/// file (`/dev/stdout`, `/proc/self/fd/1`, the terminal or pipe standard output is). The data
/// then owns standard output, and a command's human-readable summary goes to stderr.
pub fn is_stdout(path: &Path) -> bool {
    use std::os::fd::AsFd;
    use std::os::unix::fs::MetadataExt;
    if path.as_os_str() == "-" {
        return true;
    }
    let Ok(target) = std::fs::metadata(path) else {
        return false;
    };
    // Data thrown away is not a stream a summary could spoil (`--out /dev/null >/dev/null`).
    if std::fs::metadata("/dev/null")
        .is_ok_and(|n| n.dev() == target.dev() && n.ino() == target.ino())
    {
        return false;
    }
    let Ok(fd) = std::io::stdout().as_fd().try_clone_to_owned() else {
        return false;
    };
    std::fs::File::from(fd)
        .metadata()
        .is_ok_and(|m| m.dev() == target.dev() && m.ino() == target.ino())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_of_standard_output() {
        assert!(is_stdout(Path::new("-")));
        // Thrown away, not a stream a summary could spoil, whatever standard output is.
        assert!(!is_stdout(Path::new("/dev/null")));
        assert!(!is_stdout(Path::new("/no/such/file")));
    }
}
