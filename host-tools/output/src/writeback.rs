//! Early writeback of a large output: once `STEP` more bytes have been written, a background
//! thread runs `fdatasync` on the file, so the disk works while the program is still computing
//! and the sync in [`crate::AtomicFile::commit`] finds little left to write.
//!
//! Durability is unchanged: commit still syncs the whole file before renaming it. An error of a
//! background sync is kept and returned by [`WritebackFile::finish`]: Linux reports a failed
//! writeback once per open file, so the final sync might not see it again. Small outputs (under
//! `STEP`) never start the thread.
use std::fs::File;
use std::io::{self, Write};
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::thread::JoinHandle;

/// Bytes written between two background syncs.
const STEP: u64 = 32 << 20;

pub(crate) struct WritebackFile {
    file: File,
    written: u64,
    /// `written` when the last background sync was asked for.
    asked: u64,
    syncer: Option<Syncer>,
}

struct Syncer {
    wake: SyncSender<()>,
    thread: JoinHandle<io::Result<()>>,
}

impl WritebackFile {
    pub(crate) fn new(file: File) -> Self {
        Self {
            file,
            written: 0,
            asked: 0,
            syncer: None,
        }
    }

    /// Asks for a background sync when `STEP` bytes were written since the last one; a sync
    /// still running (or asked for) covers the new bytes later, so none is queued behind it.
    fn maybe_sync(&mut self) -> io::Result<()> {
        if self.written - self.asked < STEP {
            return Ok(());
        }
        if self.syncer.is_none() {
            let file = self.file.try_clone()?;
            let (wake, asked) = mpsc::sync_channel::<()>(1);
            let thread = std::thread::Builder::new()
                .name("output-writeback".into())
                .spawn(move || {
                    for () in asked {
                        file.sync_data()?;
                    }
                    Ok(())
                })?;
            self.syncer = Some(Syncer { wake, thread });
        }
        if let Some(syncer) = &self.syncer {
            match syncer.wake.try_send(()) {
                Ok(()) => self.asked = self.written,
                Err(TrySendError::Full(())) => {}
                // The thread stopped on an error: `finish` reports it.
                Err(TrySendError::Disconnected(())) => {}
            }
        }
        Ok(())
    }

    /// Stops the background syncs and syncs the whole file (data and metadata); the first error
    /// of any sync is returned.
    pub(crate) fn finish(mut self) -> io::Result<File> {
        if let Some(Syncer { wake, thread }) = self.syncer.take() {
            drop(wake);
            thread
                .join()
                .map_err(|_| io::Error::other("the writeback thread panicked"))??;
        }
        self.file.sync_all()?;
        Ok(self.file)
    }
}

impl Write for WritebackFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.file.write(buf)?;
        self.written += n as u64;
        self.maybe_sync()?;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    #[test]
    fn every_byte_arrives_across_background_syncs() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big");
        let mut out = WritebackFile::new(File::create(&path).unwrap());
        let block: Vec<u8> = (0..=255u8).cycle().take(1 << 20).collect();
        // 3.5 STEPs: at least three background syncs, then a tail only the final sync covers.
        let blocks = (STEP as usize * 7 / 2) / block.len();
        for k in 0..blocks {
            out.write_all(&block[k % 7..]).unwrap();
        }
        assert!(out.syncer.is_some(), "no background sync was started");
        out.finish().unwrap();
        let mut back = Vec::new();
        File::open(&path).unwrap().read_to_end(&mut back).unwrap();
        let mut expected = Vec::new();
        for k in 0..blocks {
            expected.extend_from_slice(&block[k % 7..]);
        }
        assert!(back == expected, "file differs from what was written");
    }

    #[test]
    fn a_small_file_starts_no_thread() {
        let dir = tempfile::tempdir().unwrap();
        let mut out = WritebackFile::new(File::create(dir.path().join("small")).unwrap());
        out.write_all(&[7u8; 1 << 16]).unwrap();
        assert!(out.syncer.is_none());
        out.finish().unwrap();
    }
}
