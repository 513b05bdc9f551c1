//! `gonio mount --record DIR`: writes the chosen parts' measuring turns for a replay (the format
//! in [`crate::formats::replay`]), of the twin's parts and of a real station's alike. It listens
//! to the station as an observer (turn boundaries, each turn's frames as the camera reported
//! them and the servo's angle log, the finished record) and to the camera's frames through the
//! station's frame tap (`gonio_station::tap`: the pixels, the camera's frame ids and times). A part
//! is written into a temporary directory and renamed into place when it is finished, so a
//! recorded part is whole or absent.

use crate::formats::replay::{FORMAT, PartFile, TurnFiles, part_dir};
use anyhow::{Context, Result, anyhow};
use gonio_station::fit::EccentricityFit;
use gonio_station::hal::CameraFrame;
use gonio_station::interval::AngleSample;
use gonio_station::observe::{Observer, Phase};
use gonio_station::record::TurnRecord;
use gonio_station::replay::{CameraStamp, RecordedTurn};
use gonio_station::tap::SeenFrame;
use gonio_station::{PartRecord, Recipe, Strategy};
use std::cell::RefCell;
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// What is recorded and where.
#[derive(Debug, Clone)]
pub struct Recording {
    /// The record directory.
    pub dir: PathBuf,
    /// 1-based part numbers to record (`None`: every part).
    pub parts: Option<BTreeSet<usize>>,
    /// 0-based index of the first part the batch mounts (a resumed batch starts later).
    pub first_part: usize,
    /// The batch's seed (`None`: a station on the wire).
    pub seed: Option<u64>,
    /// The station's name.
    pub station: String,
    /// Whether the parts are the digital twin's.
    pub simulated: bool,
    /// The recipe.
    pub recipe: Recipe,
    /// The strategy.
    pub strategy: Strategy,
    /// The software.
    pub software_version: String,
    /// How the front end removes the directories made for the record if the run is interrupted.
    pub guard: DirGuard,
}

/// The front end's cleanup of interrupted runs (a signal handler that removes directories): the
/// recorder tells it which directories to remove when the run is interrupted and which to keep.
/// Nothing here prints or installs a handler itself.
#[derive(Debug, Clone, Copy)]
pub struct DirGuard {
    /// Installs the cleanup (called once, after the record directory is made).
    pub install: fn(),
    /// Creates a directory with the given function and registers it (removed, if empty, when
    /// the run is interrupted) as one step: a signal between the two cannot leave it behind.
    pub created_dir: fn(&Path, &mut dyn FnMut() -> std::io::Result<()>) -> std::io::Result<()>,
    /// Makes a temporary directory with the given function and registers it (removed if the
    /// run is interrupted) as one step: a signal between the two cannot leave it behind.
    pub temporary_dir: fn(&mut TempDirMaker<'_>) -> std::io::Result<tempfile::TempDir>,
    /// A directory no longer to be removed (moved into place, or dropped).
    pub release: fn(&Path),
}

/// Makes a temporary directory (for [`DirGuard::temporary_dir`]).
pub type TempDirMaker<'a> = dyn FnMut() -> std::io::Result<tempfile::TempDir> + 'a;

impl DirGuard {
    /// No cleanup: every call does nothing.
    pub const NONE: DirGuard = DirGuard {
        install: || {},
        created_dir: |_, make| make(),
        temporary_dir: |make| make(),
        release: |_| {},
    };
}

struct Part {
    index: usize,
    serial: String,
    tmp: tempfile::TempDir,
    turns: Vec<TurnFiles>,
    raw: Option<std::io::BufWriter<std::fs::File>>,
    raw_frames: usize,
    /// The camera's frame ids and times of the turn's frames so far.
    camera: Vec<CameraStamp>,
    size: Option<(usize, usize)>,
    /// The last ended turn, until its record gives its start, kind and focus.
    pending: Option<RecordedTurn>,
}

struct State {
    plan: Recording,
    next: usize,
    measuring: bool,
    part: Option<Part>,
    error: Option<anyhow::Error>,
    written: Vec<PathBuf>,
}

/// The recorder: an observer of the station (see [`Recorder::tap`] for the frames).
#[derive(Clone)]
pub struct Recorder(Rc<RefCell<State>>);

/// `--record-parts 3,17`: 1-based part numbers within `1..=parts`.
///
/// # Errors
/// A number that is not a whole number in range.
pub fn parse_parts(s: &str, parts: usize) -> Result<BTreeSet<usize>> {
    let mut set = BTreeSet::new();
    for tok in s.split(',').map(str::trim) {
        let n: usize = tok.parse().map_err(|_| {
            anyhow!("--record-parts {s}: {tok:?} is not a part number; expected 1-based part numbers separated by commas, e.g. 3,17")
        })?;
        if n == 0 || n > parts {
            return Err(anyhow!(
                "--record-parts {s}: part {n} is not in the batch (1 to {parts})"
            ));
        }
        set.insert(n);
    }
    Ok(set)
}

impl Recorder {
    /// A recorder writing into `plan.dir` (created if missing).
    ///
    /// # Errors
    /// The directory cannot be created.
    pub fn new(plan: Recording) -> Result<Recorder> {
        // A directory made now is removed again if the run is interrupted before a part is in
        // it (SIGINT, SIGTERM): nothing is left behind.
        let mut first_missing = None;
        let mut d = plan.dir.as_path();
        while !d.as_os_str().is_empty() && !d.exists() {
            first_missing = Some(d.to_path_buf());
            d = d.parent().unwrap_or(Path::new(""));
        }
        // Made and registered as one step: a signal removes it, or finds it not made yet.
        let mut make = || std::fs::create_dir_all(&plan.dir);
        match &first_missing {
            Some(d) => (plan.guard.created_dir)(d, &mut make),
            None => make(),
        }
        .with_context(|| {
            format!(
                "--record {}: cannot create the directory",
                plan.dir.display()
            )
        })?;
        (plan.guard.install)();
        let next = plan.first_part;
        Ok(Recorder(Rc::new(RefCell::new(State {
            plan,
            next,
            measuring: false,
            part: None,
            error: None,
            written: Vec::new(),
        }))))
    }

    /// Takes a camera frame (pixels and the detector's result): kept when a recorded part is
    /// measuring a turn.
    pub fn tap(&self, f: &SeenFrame<'_>) {
        let mut s = self.0.borrow_mut();
        if !s.measuring || s.error.is_some() {
            return;
        }
        let r = match s.part.as_mut() {
            Some(p) => p.frame(f),
            None => return,
        };
        if let Err(e) = r {
            s.fail(e);
        }
    }

    /// The directories written, and the first error (recording stopped there).
    pub fn finish(self) -> (Vec<PathBuf>, Option<anyhow::Error>) {
        let mut s = self.0.borrow_mut();
        (std::mem::take(&mut s.written), s.error.take())
    }
}

impl Part {
    fn frame(&mut self, f: &SeenFrame<'_>) -> Result<()> {
        match self.size {
            None => self.size = Some((f.width, f.height)),
            Some(wh) if wh != (f.width, f.height) => {
                return Err(anyhow!(
                    "frame of {}x{} after frames of {}x{}",
                    f.width,
                    f.height,
                    wh.0,
                    wh.1
                ));
            }
            Some(_) => {}
        }
        if self.raw.is_none() {
            let name = format!("turn-{}.raw", self.turns.len() + 1);
            let file = std::fs::File::create(self.tmp.path().join(&name))
                .with_context(|| format!("creating {name}"))?;
            self.raw = Some(std::io::BufWriter::with_capacity(1 << 20, file));
            self.raw_frames = 0;
        }
        if let Some(w) = self.raw.as_mut() {
            w.write_all(f.pixels).context("writing frames")?;
        }
        self.raw_frames += 1;
        self.camera.push(CameraStamp {
            frame_id: f.stamp.index,
            timestamp_s: f.stamp.start_s,
        });
        Ok(())
    }

    fn end_turn(&mut self, frames: &[CameraFrame], log: &[AngleSample]) -> Result<()> {
        let n = self.turns.len() + 1;
        let raw = format!("turn-{n}.raw");
        match self.raw.take() {
            Some(mut w) => w.flush().with_context(|| format!("writing {raw}"))?,
            None => {
                // A turn without rendered frames (none reached the tap): an empty file.
                std::fs::File::create(self.tmp.path().join(&raw))
                    .with_context(|| format!("creating {raw}"))?;
                self.raw_frames = 0;
            }
        }
        if self.raw_frames != frames.len() {
            return Err(anyhow!(
                "turn {n}: {} frames rendered, {} reported by the camera",
                self.raw_frames,
                frames.len()
            ));
        }
        let data = format!("turn-{n}.json");
        // Start, kind and focus are filled in from the turn's record (Observer::turn).
        let turn = RecordedTurn {
            t_start_s: f64::NAN,
            kind: gonio_station::record::TurnKind::Initial,
            focus_um: None,
            frames: frames.to_vec(),
            log: log.to_vec(),
            camera: std::mem::take(&mut self.camera),
        };
        self.pending = Some(turn);
        self.turns.push(TurnFiles {
            raw,
            data,
            frames: frames.len(),
        });
        Ok(())
    }
}

impl State {
    fn fail(&mut self, e: anyhow::Error) {
        let what = match &self.part {
            Some(p) => format!("recording part {} ({})", p.index + 1, p.serial),
            None => "recording".into(),
        };
        self.error = Some(e.context(what));
        self.part = None;
    }

    fn write_turn(&mut self, t: &TurnRecord) -> Result<()> {
        let Some(p) = self.part.as_mut() else {
            return Ok(());
        };
        let Some(mut turn) = p.pending.take() else {
            return Ok(());
        };
        turn.t_start_s = t.t_start_s;
        turn.kind = t.kind;
        turn.focus_um = t.focus_um;
        let files = p.turns.last().expect("a turn was ended");
        let text = serde_json::to_string(&turn)?;
        std::fs::write(p.tmp.path().join(&files.data), text)
            .with_context(|| format!("writing {}", files.data))?;
        Ok(())
    }

    fn finish_part(&mut self, record: &PartRecord) -> Result<()> {
        let Some(p) = self.part.take() else {
            return Ok(());
        };
        let (width, height) = p.size.unwrap_or((0, 0));
        let file = PartFile {
            format: FORMAT.into(),
            serial: p.serial.clone(),
            batch_index: p.index,
            seed: self.plan.seed,
            station: Some(self.plan.station.clone()),
            simulated: Some(self.plan.simulated),
            software_version: self.plan.software_version.clone(),
            recipe: self.plan.recipe.clone(),
            strategy: self.plan.strategy,
            optics: self.plan.recipe.optics(),
            width,
            height,
            turns: p.turns.clone(),
            record: record.clone(),
        };
        std::fs::write(
            p.tmp.path().join("part.json"),
            serde_json::to_string_pretty(&file)?,
        )
        .context("writing part.json")?;
        let dest = part_dir(&self.plan.dir, p.index);
        if dest.exists() {
            std::fs::remove_dir_all(&dest)
                .with_context(|| format!("replacing {}", dest.display()))?;
        }
        let tmp = p.tmp.keep();
        let moved = std::fs::rename(&tmp, &dest);
        (self.plan.guard.release)(&tmp);
        if moved.is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        moved.with_context(|| format!("moving the record into {}", dest.display()))?;
        self.written.push(dest);
        Ok(())
    }
}

impl Observer for Recorder {
    fn part_started(&mut self, serial: &str) {
        let mut s = self.0.borrow_mut();
        let index = s.next;
        s.next += 1;
        s.measuring = false;
        let wanted = s
            .plan
            .parts
            .as_ref()
            .is_none_or(|set| set.contains(&(index + 1)));
        if !wanted || s.error.is_some() {
            s.part = None;
            return;
        }
        let prefix = format!(".part-{:04}-", index + 1);
        let dir = s.plan.dir.clone();
        let tmp = (s.plan.guard.temporary_dir)(&mut || {
            tempfile::Builder::new().prefix(&prefix).tempdir_in(&dir)
        });
        match tmp {
            Ok(tmp) => {
                if let Some(old) = s.part.take() {
                    (s.plan.guard.release)(old.tmp.path());
                }
                s.part = Some(Part {
                    index,
                    serial: serial.to_string(),
                    tmp,
                    turns: Vec::new(),
                    raw: None,
                    raw_frames: 0,
                    camera: Vec::new(),
                    size: None,
                    pending: None,
                })
            }
            Err(e) => s.fail(anyhow!(e).context("creating a temporary directory")),
        }
    }

    fn phase(&mut self, phase: Phase) {
        self.0.borrow_mut().measuring = matches!(phase, Phase::Measure(_));
    }

    fn turn_inputs(&mut self, frames: &[CameraFrame], log: &[AngleSample]) {
        let mut s = self.0.borrow_mut();
        s.measuring = false;
        let r = match s.part.as_mut() {
            Some(p) => p.end_turn(frames, log),
            None => return,
        };
        if let Err(e) = r {
            s.fail(e);
        }
    }

    fn turn(&mut self, turn: &TurnRecord, _fit: Option<&EccentricityFit>) {
        let mut s = self.0.borrow_mut();
        if let Err(e) = s.write_turn(turn) {
            s.fail(e);
        }
    }

    fn part_finished(&mut self, record: &PartRecord) {
        let mut s = self.0.borrow_mut();
        if let Err(e) = s.finish_part(record) {
            s.fail(e);
        }
    }
}
