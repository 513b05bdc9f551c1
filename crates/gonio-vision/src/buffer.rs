//! Row buffers: [`Aligned`] (a buffer whose first element sits on a cache line), the
//! [`RowBuf`] a row is copied into, [`next_set`] (the next non-zero byte of a mask row) and
//! the morphology's padded rows ([`PAD`], [`padded_stride`]).
//! Below every stage and the row types ([`crate::row_types`]).

/// The first index ≥ `from` whose byte is not zero (`bytes.len()` when none): eight bytes at a
/// time, for the sparse masks of edge and candidate pixels.
///
/// ```
/// use gonio_vision::rows::next_set;
/// let m = [0u8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0];
/// assert_eq!(next_set(&m, 0), 10);
/// assert_eq!(next_set(&m, 11), 12);
/// ```
#[inline(always)]
pub fn next_set(bytes: &[u8], from: usize) -> usize {
    let mut x = from;
    while let Some(chunk) = bytes.get(x..x + 8) {
        let word = u64::from_le_bytes(chunk.try_into().unwrap_or([0; 8]));
        if word != 0 {
            return x + (word.trailing_zeros() / 8) as usize;
        }
        x += 8;
    }
    while x < bytes.len() && bytes[x] == 0 {
        x += 1;
    }
    x.min(bytes.len())
}

/// A buffer whose first element sits on a 64-byte boundary (a cache line, an AVX-512 register):
/// vector stores that straddle two cache lines cost the core twice, and the row passes store a
/// whole row each. Safe code: a few elements more are allocated and the slice starts at the
/// first aligned one.
#[derive(Debug)]
pub struct Aligned<T> {
    buf: Vec<T>,
    off: usize,
    len: usize,
}

impl<T: Copy> Aligned<T> {
    /// `len` elements of value `v`, the first one 64-byte aligned.
    pub fn new(len: usize, v: T) -> Self {
        let size = std::mem::size_of::<T>().max(1);
        let buf = vec![v; len + 64 / size];
        // Elements from the allocation's start to the next 64-byte boundary (T's alignment
        // divides its size, and its size divides 64 for the types used here).
        let off = (buf.as_ptr() as usize).wrapping_neg() % 64 / size;
        Aligned { buf, off, len }
    }
}

impl<T: Copy> Clone for Aligned<T> {
    fn clone(&self) -> Self {
        let mut c = Aligned::new(self.len, self.buf[0]);
        c.copy_from_slice(self);
        c
    }
}

impl<T: Copy + Default> Default for Aligned<T> {
    fn default() -> Self {
        Aligned::new(0, T::default())
    }
}

impl<T: PartialEq> PartialEq for Aligned<T> {
    fn eq(&self, o: &Self) -> bool {
        **self == **o
    }
}

impl<T: Eq> Eq for Aligned<T> {}

impl<T> std::ops::Deref for Aligned<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[self.off..self.off + self.len]
    }
}

impl<T> std::ops::DerefMut for Aligned<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.off..self.off + self.len]
    }
}

/// Elements of `T` in 64 bytes' worth, at least one: row strides are rounded up to it so that
/// every row of an [`Aligned`] buffer starts on a cache line.
pub const fn line<T>() -> usize {
    let s = std::mem::size_of::<T>();
    if s == 0 || s >= 64 { 1 } else { 64 / s }
}

/// A row buffer a row can be copied into (what [`RowStage::push_row`](crate::rows::RowStage::push_row) does with its input).
pub trait RowBuf {
    /// Copies `src` (of the same width) into this buffer.
    fn copy_row(&mut self, src: &Self);
}

impl<T: Copy> RowBuf for [T] {
    fn copy_row(&mut self, src: &Self) {
        self.copy_from_slice(src);
    }
}

/// Columns a padded row carries before column 0: 64, so that the register kernel's stores
/// into padded rows (the first operation's rows, and the top-hat's straight into the opening's
/// ring) are aligned; the kernel's loads of the 32 columns either side of a vector then cross
/// a cache line (fewer of them than the stores, and cheaper).
pub const PAD: usize = 64;

/// Bytes of a padded row of `width` pixels: [`PAD`] columns before column 0 and whole
/// 64-column vectors plus 128 after it (the class loop loads the 128 columns around a vector
/// and the same shifted by one).
pub fn padded_stride(width: usize) -> usize {
    width.div_ceil(64) * 64 + 128
}
