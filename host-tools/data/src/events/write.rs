//! Writing event folders. Numbers are written in Rust's shortest round-trip form, so a folder
//! written here loads back bit-exactly (f32 states, f64 times). Both files are written through
//! temporary files and renamed into place by [`EventWriter::finish`], so a failed or interrupted
//! write never leaves half a folder over a good one.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use riskscore_output::{AtomicFile, AtomicSet, NewFolders};

use super::load::EventsError;
use super::{Event, EventSet, EVENTS_FILE, EVENT_COLUMNS, FRAMES_FILE, FRAME_COLUMNS};

/// Streams events into a folder: one `events.csv` row and the frames of each event as it comes,
/// so a writer of 100,000 events holds one event at a time.
pub struct EventWriter {
    dir: PathBuf,
    events: csv::Writer<AtomicFile>,
    frames: csv::Writer<AtomicFile>,
    buf: String,
    /// The folders made for this writer, removed again if it does not finish.
    new_folders: NewFolders,
    /// Also write the optional `acc_sur` column (partner acceleration known from the source).
    partner_acc: bool,
}

fn io_err(path: &Path, e: std::io::Error) -> EventsError {
    EventsError::Io {
        path: path.to_path_buf(),
        source: e,
    }
}

/// A write error is the file's, not a line's (no `line 0`): `frames.csv: No space left on device`.
fn csv_err(path: &Path, e: csv::Error) -> EventsError {
    let source = match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => std::io::Error::other(format!("{other:?}")),
    };
    io_err(path, source)
}

impl EventWriter {
    /// Creates `dir` (and parents) and both files with their headers, replacing existing files.
    pub fn create(dir: &Path) -> Result<Self, EventsError> {
        Self::open(dir, false)
    }

    /// Like [`EventWriter::create`], but `frames.csv` also gets the optional `acc_sur` column,
    /// written from `partner.acc`: for sources that record the partner's acceleration, so the loader
    /// uses it instead of deriving it from the partner's velocity.
    pub fn create_with_partner_acceleration(dir: &Path) -> Result<Self, EventsError> {
        Self::open(dir, true)
    }

    fn open(dir: &Path, partner_acc: bool) -> Result<Self, EventsError> {
        if std::fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
            return Err(io_err(
                dir,
                std::io::Error::other(
                    "it is a file, not a folder: an event folder is written here",
                ),
            ));
        }
        let new_folders = NewFolders::create(dir).map_err(|e| io_err(dir, e))?;
        let open = |name: &str| -> Result<csv::Writer<AtomicFile>, EventsError> {
            let path = dir.join(name);
            let f = AtomicFile::create(&path).map_err(|e| io_err(&path, e))?;
            Ok(csv::Writer::from_writer(f))
        };
        let mut events = open(EVENTS_FILE)?;
        let mut frames = open(FRAMES_FILE)?;
        events
            .write_record(EVENT_COLUMNS)
            .map_err(|e| csv_err(&dir.join(EVENTS_FILE), e))?;
        let extra: &[&str] = if partner_acc { &["acc_sur"] } else { &[] };
        frames
            .write_record(FRAME_COLUMNS.iter().chain(extra))
            .map_err(|e| csv_err(&dir.join(FRAMES_FILE), e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            events,
            frames,
            buf: String::new(),
            new_folders,
            partner_acc,
        })
    }

    /// Appends one event (its `events.csv` row and all its frames). The partner acceleration
    /// (`partner.acc`) is written only by a writer made with
    /// [`EventWriter::create_with_partner_acceleration`].
    pub fn write_event(&mut self, ev: &Event) -> Result<(), EventsError> {
        let ep = self.dir.join(EVENTS_FILE);
        let fp = self.dir.join(FRAMES_FILE);
        let d = ev.dims;
        let t_impact = ev.t_impact.map(|t| t.to_string()).unwrap_or_default();
        self.events
            .write_record([
                ev.id.as_str(),
                ev.kind.as_str(),
                &ev.t_start.to_string(),
                &ev.t_end.to_string(),
                &t_impact,
                &d.length_ego.to_string(),
                &d.width_ego.to_string(),
                &d.length_partner.to_string(),
                &d.width_partner.to_string(),
            ])
            .map_err(|e| csv_err(&ep, e))?;
        for fr in &ev.frames {
            let w = &mut self.frames;
            w.write_field(&ev.id).map_err(|e| csv_err(&fp, e))?;
            let (e, s) = (&fr.ego, &fr.partner);
            self.buf.clear();
            let _ = write!(self.buf, "{}", fr.time);
            w.write_field(&self.buf).map_err(|e| csv_err(&fp, e))?;
            for v in [
                e.x, e.y, e.vx, e.vy, e.hx, e.hy, e.acc, s.x, s.y, s.vx, s.vy, s.hx, s.hy,
            ] {
                self.buf.clear();
                let _ = write!(self.buf, "{v}");
                w.write_field(&self.buf).map_err(|e| csv_err(&fp, e))?;
            }
            if self.partner_acc {
                self.buf.clear();
                let _ = write!(self.buf, "{}", s.acc);
                w.write_field(&self.buf).map_err(|e| csv_err(&fp, e))?;
            }
            w.write_record(None::<&[u8]>).map_err(|e| csv_err(&fp, e))?;
        }
        Ok(())
    }

    /// Flushes both files and renames them into place (`events.csv` first). Without `finish` (an
    /// error, a panic) the folder keeps its previous files.
    pub fn finish(self) -> Result<(), EventsError> {
        self.finish_with(Vec::new())
    }

    /// Like [`EventWriter::finish`], with more files of the same folder (`scenarios.csv`): every
    /// file is flushed and synced before any is renamed into place.
    pub fn finish_with(self, extra: Vec<AtomicFile>) -> Result<(), EventsError> {
        let (ep, fp) = (self.dir.join(EVENTS_FILE), self.dir.join(FRAMES_FILE));
        let events = self
            .events
            .into_inner()
            .map_err(|e| io_err(&ep, e.into_error()))?;
        let frames = self
            .frames
            .into_inner()
            .map_err(|e| io_err(&fp, e.into_error()))?;
        let mut set = AtomicSet::default();
        set.push(events);
        set.push(frames);
        extra.into_iter().for_each(|f| set.push(f));
        // The set's errors name the file.
        set.commit().map_err(|e| io_err(&self.dir, e))?;
        self.new_folders.keep();
        Ok(())
    }

    /// The folder being written.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// Writes `set` as an event folder in `dir` (created if needed; existing files are replaced).
pub fn write_events(dir: &Path, set: &EventSet) -> Result<(), EventsError> {
    let mut w = EventWriter::create(dir)?;
    for ev in set {
        w.write_event(ev)?;
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::{load_events, Dims, EventKind, Frame};

    fn event(id: &str) -> Event {
        let state = scorer_core::VehicleState {
            vx: 10.0,
            hx: 1.0,
            length: 4.5,
            width: 1.8,
            ..Default::default()
        };
        Event {
            id: id.to_owned(),
            kind: EventKind::Safe,
            t_start: 0.0,
            t_end: 0.1,
            t_impact: None,
            dims: Dims {
                length_ego: 4.5,
                width_ego: 1.8,
                length_partner: 4.5,
                width_partner: 1.8,
            },
            frames: (0..2)
                .map(|i| Frame {
                    time: f64::from(i) * 0.1,
                    ego: state,
                    partner: scorer_core::VehicleState { x: 20.0, ..state },
                })
                .collect(),
        }
    }

    #[test]
    fn an_unfinished_writer_leaves_the_folder_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        write_events(
            dir.path(),
            &EventSet {
                events: vec![event("old")],
            },
        )
        .unwrap();
        let before = std::fs::read(dir.path().join(FRAMES_FILE)).unwrap();
        {
            let mut w = EventWriter::create(dir.path()).unwrap();
            w.write_event(&event("new")).unwrap();
            // Dropped without `finish`, as on an error or a panic.
        }
        assert_eq!(std::fs::read(dir.path().join(FRAMES_FILE)).unwrap(), before);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "temporary files left: {names:?}");
        let (set, issues) = load_events(dir.path()).unwrap();
        assert!(issues.is_empty());
        assert_eq!(set.events[0].id, "old");
    }
}
