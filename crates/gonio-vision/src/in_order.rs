//! [`detect_in_order`]: the path of [`SourceDetector`](crate::SourceDetector) on several threads
//! for a recorded stream, each frame detected from a fresh start, the results handed on in the
//! stream's order; errors are the source's, a frame's or the sink's ([`DetectInOrderError`]).

use crate::source::detect_frame;
use crate::{
    Detection, Detector, FrameResult, FrameSource, FrameStamp, Optics, SourceError, VisionError,
};
use thiserror::Error;

/// The source as the workers share it: who reads next, and whether reading has stopped.
struct Reader<S> {
    source: S,
    /// Frames read so far (the next frame's sequence number).
    read: u64,
    /// Frames handed to the sink so far.
    emitted: u64,
    /// No more reads: the source ended or failed, or the sink stopped the run.
    stopped: bool,
}

/// A worker's message to the calling thread (one per frame, moved once: the size difference of
/// the variants costs nothing worth a box).
#[allow(clippy::large_enum_variant)]
enum Done<E: std::error::Error + 'static> {
    /// Frame `seq` detected (or refused).
    Frame {
        seq: u64,
        stamp: FrameStamp,
        result: Result<FrameResult, SourceError<E>>,
    },
    /// The source ended after `seq` frames, or failed reading frame `seq`.
    End { seq: u64, error: Option<E> },
}

/// Detects every frame of `source` on `threads` worker threads (each with its own detector) and
/// hands each frame's outcome to `sink` in the source's order, with the source (to name a frame's
/// file, say). Each worker reads its next frame itself (the source behind a lock, frames numbered
/// in the order read) and detects it on the same core, so the frame is still in that core's cache
/// when the detector reads it and no buffer goes from thread to thread; at most one frame per
/// worker is being detected, and reading waits while two frames per worker are read and not yet
/// handed on (a slow sink holds the reading back). A frame the detector refuses (wrong size)
/// reaches `sink` as [`SourceError::Frame`] in its place; a failing source as [`SourceError::Source`] after every
/// frame before it, and nothing is read after it. Results equal [`SourceDetector`](crate::SourceDetector)'s bit for bit:
/// every frame goes through the same detector code from a fresh frame start.
///
/// For a live camera, where each result is wanted as soon as its frame is in, use
/// [`SourceDetector`](crate::SourceDetector) (one frame in flight).
///
/// # Errors
/// [`VisionError::Optics`] for invalid optics (nothing is read); the first error `sink` returns
/// (reading stops, the frames in flight are finished and dropped).
///
/// ```
/// use gonio_vision::{Optics, RawFrames, detect_in_order};
/// let optics = Optics { window_width_px: 96, window_height_px: 48, ..Optics::default() };
/// let mut frame = vec![200u8; 96 * 48];
/// for row in frame.chunks_mut(96) {
///     for x in 25..=35 { row[x] = 60; }
/// }
/// let bytes = [frame.clone(), frame.clone(), frame].concat();
/// let mut seen = Vec::new();
/// detect_in_order(RawFrames::new(&bytes[..], 96, 48), &optics, 2, |_, d| {
///     seen.push(d.unwrap().stamp.index);
///     Ok::<(), std::convert::Infallible>(())
/// })
/// .unwrap();
/// assert_eq!(seen, [0, 1, 2]); // in the stream's order
/// ```
pub fn detect_in_order<S, F, E>(
    source: S,
    optics: &Optics,
    threads: usize,
    mut sink: F,
) -> Result<(), DetectInOrderError<E>>
where
    S: FrameSource + Send,
    S::Error: Send,
    F: FnMut(&S, Result<Detection, SourceError<S::Error>>) -> Result<(), E>,
{
    use std::collections::BTreeMap;
    use std::sync::{Condvar, Mutex, PoisonError, mpsc};
    let threads = threads.max(1);
    let mut detectors = (0..threads)
        .map(|_| Detector::new(optics))
        .collect::<Result<Vec<_>, _>>()
        .map_err(DetectInOrderError::Vision)?;
    let n = detectors[0].params().width * detectors[0].params().height;
    let reader = Mutex::new(Reader {
        source,
        read: 0,
        emitted: 0,
        stopped: false,
    });
    // Signalled when frames are handed on or the run stops.
    let room = Condvar::new();
    let ahead = 2 * threads as u64;
    // A worker that panicked holding the lock leaves the source as it was: the panic itself
    // reaches the caller when the scope ends.
    let lock = || reader.lock().unwrap_or_else(PoisonError::into_inner);
    let (done_tx, done_rx) = mpsc::channel::<Done<S::Error>>();
    std::thread::scope(|scope| {
        for det in detectors.iter_mut() {
            let (lock, room, done_tx) = (&lock, &room, done_tx.clone());
            scope.spawn(move || {
                let (mut raw, mut scratch) = (Vec::with_capacity(n), Vec::new());
                loop {
                    let (seq, hdr) = {
                        let mut r = lock();
                        while !r.stopped && r.read >= r.emitted + ahead {
                            r = room.wait(r).unwrap_or_else(PoisonError::into_inner);
                        }
                        if r.stopped {
                            return;
                        }
                        let seq = r.read;
                        match r.source.next_frame(&mut raw) {
                            Ok(Some(hdr)) => {
                                r.read += 1;
                                (seq, hdr)
                            }
                            end => {
                                r.stopped = true;
                                let error = end.err();
                                let _ = done_tx.send(Done::End { seq, error });
                                return;
                            }
                        }
                    };
                    let result = detect_frame(optics, det, None, None, &hdr, &raw, &mut scratch);
                    let done = Done::Frame {
                        seq,
                        stamp: hdr.stamp,
                        result,
                    };
                    if done_tx.send(done).is_err() {
                        return;
                    }
                }
            });
        }
        drop(done_tx);
        let mut emitted = 0u64;
        let mut end: Option<(u64, Option<S::Error>)> = None;
        let mut waiting = BTreeMap::new();
        let outcome = loop {
            if let Some((seq, error)) = &mut end
                && *seq == emitted
            {
                break match error.take() {
                    Some(e) => sink(&lock().source, Err(SourceError::Source(e))),
                    None => Ok(()),
                };
            }
            // Every worker gone without an end: only after a panic, which the scope passes on.
            let Ok(done) = done_rx.recv() else {
                break Ok(());
            };
            match done {
                Done::Frame { seq, stamp, result } => {
                    waiting.insert(seq, (stamp, result));
                }
                Done::End { seq, error } => end = Some((seq, error)),
            }
            let mut failed = None;
            while let Some((stamp, result)) = waiting.remove(&emitted) {
                emitted += 1;
                let item = result.map(|result| Detection { stamp, result });
                let mut r = lock();
                let handed = sink(&r.source, item);
                // A refused frame makes no room: the reading stops under the same lock.
                match handed {
                    Ok(()) => r.emitted = emitted,
                    Err(_) => r.stopped = true,
                }
                drop(r);
                room.notify_all();
                if let Err(e) = handed {
                    failed = Some(e);
                    break;
                }
            }
            if let Some(e) = failed {
                break Err(e);
            }
        };
        // The workers stop at their next read.
        lock().stopped = true;
        room.notify_all();
        outcome.map_err(DetectInOrderError::Sink)
    })
}

/// An error of [`detect_in_order`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DetectInOrderError<E> {
    /// The optics are invalid.
    #[error(transparent)]
    Vision(VisionError),
    /// The sink stopped the run.
    #[error("{0}")]
    Sink(E),
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::SourceDetector;
    use crate::test_frames::{Fault, optics, source};

    #[test]
    fn results_come_in_order_and_equal_one_frame_at_a_time() {
        let mut one = SourceDetector::new(source(40, None), &optics()).unwrap();
        let mut expected = Vec::new();
        while let Some(d) = one.detect_next().unwrap() {
            expected.push(d);
        }
        assert_eq!(expected.len(), 40);
        for threads in [1, 2, 3, 7] {
            let mut got = Vec::new();
            detect_in_order(source(40, None), &optics(), threads, |_, d| {
                got.push(d.unwrap());
                Ok::<(), Fault>(())
            })
            .unwrap();
            assert_eq!(got, expected, "{threads} threads");
        }
    }

    #[test]
    fn a_failing_source_ends_the_run_after_every_frame_before_it() {
        for threads in [1, 2, 3] {
            let mut seen = Vec::new();
            let mut error = None;
            detect_in_order(source(40, Some(13)), &optics(), threads, |s, d| {
                match d {
                    Ok(d) => seen.push(d.stamp.index),
                    Err(SourceError::Source(e)) => error = Some((e.0, s.asked)),
                    Err(e) => panic!("{e}"),
                }
                Ok::<(), Fault>(())
            })
            .unwrap();
            assert_eq!(seen, (0..13).collect::<Vec<_>>(), "{threads} threads");
            // The failed read is the last one: 13 frames and the fault.
            assert_eq!(error, Some((13, 14)), "{threads} threads");
        }
    }

    #[test]
    fn a_failing_sink_stops_the_reading() {
        for threads in [1, 2, 3] {
            let mut seen = 0;
            let mut src = source(1000, None);
            let err = detect_in_order(&mut src, &optics(), threads, |_, _| {
                seen += 1;
                if seen == 5 { Err(Fault(5)) } else { Ok(()) }
            })
            .unwrap_err();
            assert!(matches!(err, DetectInOrderError::Sink(Fault(5))));
            assert_eq!(seen, 5);
            // At most two frames per worker beyond the four handed on before the failure.
            assert!(src.asked <= 4 + 2 * threads as u64, "{} reads", src.asked);
        }
    }
}
