//! The crate's only `unsafe`: the calls of libaravis that the `aravis` crate's safe API lacks
//! (`arv_enable_interface`, the device list with serial numbers, `arv_fake_camera_set_fill_pattern`
//! with a Rust closure behind it) and a borrowed view of a buffer's bytes.
#![allow(unsafe_code)]

use aravis::glib::translate::ToGlibPtr;
use std::ffi::{CStr, CString, c_void};
use std::sync::Mutex;

/// Aravis's device list is global state: one caller at a time.
static DEVICE_LIST: Mutex<()> = Mutex::new(());

/// Enables an Aravis interface by id (`"Fake"`: the in-process fake device, off by default).
pub(crate) fn enable_interface(id: &str) {
    let Ok(c) = CString::new(id) else { return };
    let _guard = DEVICE_LIST.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: `c` is a valid NUL-terminated string that outlives the call; Aravis copies what it
    // needs. The interface table is global: the lock serialises the callers in this process.
    unsafe { aravis_sys::arv_enable_interface(c.as_ptr()) }
}

/// One device of Aravis's list, as strings.
#[derive(Debug, Clone)]
pub(crate) struct RawDevice {
    pub id: String,
    pub vendor: String,
    pub model: String,
    pub serial: String,
    pub address: String,
    pub protocol: String,
}

/// A string of Aravis's device list (`""` for NULL).
///
/// # Safety
/// `p` is NULL or points to a NUL-terminated string valid for the call.
unsafe fn owned(p: *const std::ffi::c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    // SAFETY: non-NULL and NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// Updates Aravis's device list (discovery on every enabled interface) and returns it.
pub(crate) fn list_devices() -> Vec<RawDevice> {
    let _guard = DEVICE_LIST.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: the device list is global state of libaravis; the lock above keeps every other
    // caller in this process out while it is updated and read. The strings returned are owned by
    // the list and valid until its next update, which cannot happen before they are copied.
    unsafe {
        aravis_sys::arv_update_device_list();
        let n = aravis_sys::arv_get_n_devices();
        (0..n)
            .map(|i| RawDevice {
                id: owned(aravis_sys::arv_get_device_id(i)),
                vendor: owned(aravis_sys::arv_get_device_vendor(i)),
                model: owned(aravis_sys::arv_get_device_model(i)),
                serial: owned(aravis_sys::arv_get_device_serial_nbr(i)),
                address: owned(aravis_sys::arv_get_device_address(i)),
                protocol: owned(aravis_sys::arv_get_device_protocol(i)),
            })
            .collect()
    }
}

/// The bytes of a buffer's data, borrowed for as long as the buffer.
pub(crate) fn buffer_bytes(buffer: &aravis::Buffer) -> &[u8] {
    let (data, size) = buffer.data();
    if data.is_null() || size == 0 {
        return &[];
    }
    // SAFETY: Aravis owns `size` bytes at `data` for the buffer's life; we hold a reference to the
    // buffer, which is popped from the stream (Aravis writes into it no more until it is pushed
    // back, which takes it by value).
    unsafe { std::slice::from_raw_parts(data, size) }
}

/// What the fill callback is told about the frame it fills.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RawFill {
    pub frame_id: u64,
    pub timestamp_ns: u64,
    pub width: u32,
    pub height: u32,
    pub pixel_format: u32,
    pub exposure_us: u32,
    pub gain: u32,
}

/// The closure behind a fake camera's fill pattern.
pub(crate) type FillFn = dyn FnMut(&RawFill, &mut [u8]) + Send;

/// Where libaravis keeps a buffer's `received_size` (the bytes the GigE Vision fake camera
/// sends), as a byte offset into the buffer's private data; found once by [`probe_layout`].
static RECEIVED_SIZE_OFFSET: std::sync::OnceLock<Option<usize>> = std::sync::OnceLock::new();

/// Byte offset of the private-data pointer in an `ArvBuffer` (`struct _ArvBuffer { GObject
/// parent; ArvBufferPrivate *priv; }`): after the `GObject`.
const PRIV_AT: usize = std::mem::size_of::<aravis::glib::gobject_ffi::GObject>();

/// The private data of `buffer` and how far it lies before the instance, when it has the
/// layout we rely on (GLib puts a type's private data right before its instance).
///
/// # Safety
/// `buffer` is a live `ArvBuffer`.
unsafe fn buffer_priv(buffer: *mut aravis_sys::ArvBuffer) -> Option<(*mut u8, usize)> {
    // SAFETY: the instance is at least a GObject followed by one pointer (the caller's live
    // buffer); the read is unaligned-safe.
    let p =
        unsafe { std::ptr::read_unaligned((buffer as *const u8).add(PRIV_AT) as *const *mut u8) };
    let dist = (buffer as usize).checked_sub(p as usize)?;
    (p as usize != 0 && (16..=512).contains(&dist)).then_some((p, dist))
}

/// Finds where a buffer's `received_size` lives: the GigE Vision fake camera sends only that many
/// bytes of a frame, and the fill callback (which Aravis's own pattern uses to set it) has no
/// public way to set it. A buffer is filled once by Aravis's own pattern for a 123 × 77 Mono8
/// frame, and the one word of its private data that then holds 9471 is the field. `None` when
/// the layout is not the expected one (then no custom fill is possible).
fn probe_layout() -> Option<usize> {
    *RECEIVED_SIZE_OFFSET.get_or_init(|| {
        const W: u32 = 123;
        const H: u32 = 77;
        let fake = aravis::FakeCamera::new("PROBE");
        fake.write_register(0x100, W); // Width
        fake.write_register(0x104, H); // Height
        let buffer = aravis::Buffer::new_allocate(20_000);
        let raw: *mut aravis_sys::ArvBuffer = buffer.to_glib_none().0;
        // SAFETY: `raw` is the live buffer held by `buffer`; we read only inside the span between
        // its private data and its instance (one allocation, checked by `buffer_priv`).
        unsafe {
            let (p, dist) = buffer_priv(raw)?;
            let words = |p: *mut u8| -> Vec<usize> {
                (0..dist / 8)
                    .map(|k| std::ptr::read_unaligned(p.add(8 * k) as *const usize))
                    .collect()
            };
            // The first field is the allocated size: the layout is the one expected.
            if words(p).first() != Some(&20_000) {
                return None;
            }
            let before = words(p);
            fake.fill_buffer(&buffer);
            let after = words(p);
            let hits: Vec<usize> = (0..after.len())
                .filter(|&k| after[k] == (W * H) as usize && before[k] != after[k])
                .collect();
            (hits.len() == 1).then(|| 8 * hits[0])
        }
    })
}

/// True when a fill callback can set what the fake camera sends (see [`probe_layout`]).
pub(crate) fn custom_fill_supported() -> bool {
    probe_layout().is_some()
}

/// The C callback: calls the closure behind `data` on the buffer's bytes.
unsafe extern "C" fn fill_trampoline(
    buffer: *mut aravis_sys::ArvBuffer,
    data: *mut c_void,
    exposure_time_us: u32,
    gain: u32,
    pixel_format: aravis_sys::ArvPixelFormat,
) {
    if buffer.is_null() || data.is_null() {
        return;
    }
    // SAFETY: `data` is the `Box<Box<FillFn>>` registered by `set_fill`, which its
    // `FillGuard` frees only after taking the pattern back under Aravis's fill mutex, the
    // mutex Aravis holds for this call.
    let f = unsafe { &mut *(data as *mut Box<FillFn>) };
    // SAFETY: `buffer` is the live buffer Aravis is filling; the getters only read it.
    let (frame_id, timestamp_ns, width, height, data) = unsafe {
        (
            aravis_sys::arv_buffer_get_frame_id(buffer),
            aravis_sys::arv_buffer_get_timestamp(buffer),
            aravis_sys::arv_buffer_get_image_width(buffer),
            aravis_sys::arv_buffer_get_image_height(buffer),
            aravis_sys::arv_buffer_get_data(buffer, std::ptr::null_mut()),
        )
    };
    let n = width.max(0) as usize * height.max(0) as usize;
    // The buffer's data reports the bytes received so far (none yet): the frame's extent is its
    // Width × Height (Mono8), within the allocation, which is the private data's first word.
    let bytes: &mut [u8] = match (probe_layout(), data.is_null()) {
        (Some(off), false) => {
            // SAFETY: the layout was checked by `probe_layout` on this library; `buffer` is live
            // and its private data spans at least `off + 8` bytes before the instance
            // (`buffer_priv`); `data` holds `allocated` bytes, of which we take at most that many;
            // Aravis's fill thread (us) is the only one touching them now.
            unsafe {
                match buffer_priv(buffer) {
                    Some((p, dist)) if off + 8 <= dist => {
                        let allocated = std::ptr::read_unaligned(p as *const usize);
                        let n = n.min(allocated);
                        std::ptr::write_unaligned(p.add(off) as *mut usize, n);
                        std::slice::from_raw_parts_mut(data, n)
                    }
                    _ => &mut [],
                }
            }
        }
        _ => &mut [],
    };
    let info = RawFill {
        frame_id,
        timestamp_ns,
        width: width.max(0) as u32,
        height: height.max(0) as u32,
        pixel_format,
        exposure_us: exposure_time_us,
        gain,
    };
    // A panic must not unwind into C: the frame is left as it is.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&info, bytes)));
}

/// A fill pattern installed on a fake camera by [`set_fill`]: the closure, and a reference to
/// the camera that calls it. Dropping the guard first puts Aravis's own pattern back, and only
/// then frees the closure. Aravis calls the pattern and swaps it under one mutex (its
/// `fill_pattern_mutex`), so once the swap returns no call of the closure is running and none
/// can start: the closure lives as long as Aravis may call it, whatever the camera's streaming
/// thread does and in whatever order the caller drops things.
pub(crate) struct FillGuard {
    camera: aravis::FakeCamera,
    holder: Option<Box<Box<FillFn>>>,
}

impl Drop for FillGuard {
    fn drop(&mut self) {
        let cam: *mut aravis_sys::ArvFakeCamera = self.camera.to_glib_none().0;
        // SAFETY: `cam` is a live fake camera (the guard holds a reference to it). A NULL
        // callback restores Aravis's default pattern; Aravis makes the swap under the mutex it
        // holds while it calls the pattern, so after this call the closure is never called
        // again and may be freed.
        unsafe {
            aravis_sys::arv_fake_camera_set_fill_pattern(cam, None, std::ptr::null_mut());
        }
        self.holder.take();
    }
}

/// Installs `f` as the fake camera's fill pattern, for as long as the returned guard lives.
pub(crate) fn set_fill(camera: &aravis::FakeCamera, f: Box<FillFn>) -> FillGuard {
    let mut holder = Box::new(f);
    let data = &mut *holder as *mut Box<FillFn> as *mut c_void;
    let cam: *mut aravis_sys::ArvFakeCamera = camera.to_glib_none().0;
    // SAFETY: `cam` is a live fake camera (we hold a reference); `data` points into the heap
    // allocation of `holder`, which does not move when the box is moved, and which the guard
    // frees only after it has taken the pattern back (see `FillGuard`).
    unsafe { aravis_sys::arv_fake_camera_set_fill_pattern(cam, Some(fill_trampoline), data) };
    FillGuard {
        camera: camera.clone(),
        holder: Some(holder),
    }
}
