//! Shift-angle ranges as an operator types them: `START:STEP:END` or one angle, degrees (the
//! readings files, the measuring plan and the simulator read the same syntax).

/// Most shifts in a range `START:STEP:END`.
pub const MAX_SHIFTS: usize = 100_000;

/// A shift of the polygon's start: 0 ≤ shift < 360°, as a readings file takes it.
pub const SHIFT_DEG: gonio_core::bound::Bound =
    gonio_core::bound::Bound::new(0.0, 360.0, "°").hi_excluded();

/// The shifts of `START:STEP:END` (inclusive end) or a single `S`, degrees; `None` when it is
/// neither, or has more than [`MAX_SHIFTS`] shifts.
///
/// ```
/// use gonio_calib::shift_angle::shift_range;
/// assert_eq!(shift_range("0:5:10"), Some(vec![0.0, 5.0, 10.0]));
/// assert_eq!(shift_range("0:1e-300:1"), None);
/// assert_eq!(shift_range("0:x:1"), None);
/// ```
pub fn shift_range(s: &str) -> Option<Vec<f64>> {
    let p: Vec<f64> = s
        .split(':')
        .map(|x| x.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    match p.as_slice() {
        [a] => Some(vec![*a]),
        [a, st, b] if *st > 0.0 && b >= a => {
            let count = ((b - a) / st + 1e-9).floor() + 1.0;
            (count.is_finite() && count <= MAX_SHIFTS as f64)
                .then(|| (0..count as usize).map(|k| a + k as f64 * st).collect())
        }
        _ => None,
    }
}
