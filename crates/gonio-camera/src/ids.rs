//! Frame ids counted on across the wrap of GigE Vision's 16-bit block ids, and the gaps in them.
//!
//! A GigE Vision 1.x camera numbers its frames (blocks) with 16 bits: after 65 535 comes 1 (the
//! standard never uses block id 0; Aravis's fake camera starts near 65 400 to make the wrap
//! come early). [`FrameIds`] turns the wire's ids into one increasing `frame_id` (the wire's id is
//! its low 16 bits) and says how many frames are missing before each one. An id of 0 skipped at
//! the wrap is not a missing frame; a camera that does send 0 is counted as well. Ids wider than
//! 16 bits (GigE Vision 2 extended ids, USB3 Vision) are taken as they are.
//!
//! ```
//! use gonio_camera::FrameIds;
//! let mut ids = FrameIds::new();
//! assert_eq!(ids.next(65534).frame_id, 65534);
//! let s = ids.next(65535);
//! assert_eq!((s.frame_id, s.missing), (65535, 0));
//! let s = ids.next(1); // 0 is skipped at the wrap: nothing missing
//! assert_eq!((s.frame_id, s.missing), (65537, 0));
//! let s = ids.next(4); // 2 and 3 are missing
//! assert_eq!((s.frame_id, s.missing, s.slot), (65540, 2, 5));
//! ```

/// One received id placed in the sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdStep {
    /// The frame's id, counted on across the 16-bit wrap (its low 16 bits are the wire's id).
    pub frame_id: u64,
    /// Frames missing between the previous id and this one.
    pub missing: u64,
    /// The frame's slot: 0 for the first id, then one per frame of the camera (received or
    /// missing; a block id 0 skipped at the wrap takes none).
    pub slot: u64,
    /// True when the id repeats the previous one or is older than it (a frame delivered late,
    /// after a newer one, already counted as missing): the frame is not counted again.
    pub repeated: bool,
}

/// Counts frame ids across the 16-bit wrap (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct FrameIds {
    last: Option<(u64, u64)>,
    wide: bool,
}

impl FrameIds {
    /// No id seen yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Places the next id received from the camera.
    pub fn next(&mut self, wire: u64) -> IdStep {
        self.wide |= wire > 0xffff;
        let Some((last, slot)) = self.last else {
            self.last = Some((wire, 0));
            return IdStep {
                frame_id: wire,
                missing: 0,
                slot: 0,
                repeated: false,
            };
        };
        let (frame_id, mut slots) = if self.wide {
            if wire <= last {
                return IdStep {
                    frame_id: last,
                    missing: 0,
                    slot,
                    repeated: true,
                };
            }
            (wire, wire - last)
        } else {
            let diff = wire.wrapping_sub(last) & 0xffff;
            // Half the id space or more ahead is behind: a late frame.
            if diff == 0 || diff >= 0x8000 {
                return IdStep {
                    frame_id: last,
                    missing: 0,
                    slot,
                    repeated: true,
                };
            }
            let id = last + diff;
            let mut slots = diff;
            // Block id 0 skipped at the wrap takes no slot (wire 0 itself is a frame).
            if (last & 0xffff) + diff > 0xffff && wire != 0 {
                slots -= 1;
            }
            (id, slots)
        };
        slots = slots.max(1);
        self.last = Some((frame_id, slot + slots));
        IdStep {
            frame_id,
            missing: slots - 1,
            slot: slot + slots,
            repeated: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_through_several_wraps() {
        let mut ids = FrameIds::new();
        let mut wire = 65_400u64;
        let mut last = ids.next(wire);
        for _ in 0..200_000 {
            wire = if wire == 65_535 { 1 } else { wire + 1 };
            let s = ids.next(wire);
            assert_eq!(s.missing, 0);
            assert_eq!(s.slot, last.slot + 1);
            assert!(s.frame_id > last.frame_id);
            assert_eq!(s.frame_id & 0xffff, wire);
            last = s;
        }
        assert_eq!(last.slot, 200_000);
    }

    #[test]
    fn a_camera_that_sends_zero_loses_nothing() {
        let mut ids = FrameIds::new();
        ids.next(65_535);
        let s = ids.next(0);
        assert_eq!((s.frame_id, s.missing, s.slot), (65_536, 0, 1));
        let s = ids.next(1);
        assert_eq!((s.frame_id, s.missing, s.slot), (65_537, 0, 2));
    }

    #[test]
    fn gaps_across_the_wrap_and_repeats() {
        let mut ids = FrameIds::new();
        ids.next(65_530);
        // 65531..65535 (5) missing, 0 skipped, 1 and 2 missing.
        let s = ids.next(3);
        assert_eq!((s.missing, s.slot), (7, 8));
        assert!(ids.next(3).repeated);
        let s = ids.next(4);
        assert_eq!((s.missing, s.slot, s.frame_id), (0, 9, 65_536 + 4));
    }

    #[test]
    fn a_late_frame_is_not_a_wrap() {
        let mut ids = FrameIds::new();
        ids.next(65_460);
        ids.next(65_462);
        let s = ids.next(65_461);
        assert!(s.repeated);
        let s = ids.next(65_463);
        assert_eq!((s.missing, s.slot), (0, 3));
        // Across the wrap too.
        ids.next(2);
        assert!(ids.next(65_535).repeated);
    }

    #[test]
    fn wide_ids_are_taken_as_they_are() {
        let mut ids = FrameIds::new();
        ids.next(1 << 40);
        let s = ids.next((1 << 40) + 3);
        assert_eq!((s.missing, s.slot), (2, 3));
    }
}
