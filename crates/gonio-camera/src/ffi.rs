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
    // SAFETY: `data` is the `Box<Box<FillFn>>` registered by `set_fill`, kept alive until the
    // fake camera's thread (the only caller, under Aravis's fill mutex) has been joined.
    let f = unsafe { &mut *(data as *mut Box<FillFn>) };
    // SAFETY: `buffer` is the live buffer Aravis is filling; the getters only read it.
    let (frame_id, timestamp_ns, width, height, bytes) = unsafe {
        let mut size = 0usize;
        let p = aravis_sys::arv_buffer_get_data(buffer, &mut size);
        (
            aravis_sys::arv_buffer_get_frame_id(buffer),
            aravis_sys::arv_buffer_get_timestamp(buffer),
            aravis_sys::arv_buffer_get_image_width(buffer),
            aravis_sys::arv_buffer_get_image_height(buffer),
            if p.is_null() {
                &mut [][..]
            } else {
                std::slice::from_raw_parts_mut(p, size)
            },
        )
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

/// Installs `f` as the fake camera's fill pattern. The returned box must outlive the camera's
/// streaming thread: drop the GigE Vision fake camera (which joins it) before the box.
pub(crate) fn set_fill(camera: &aravis::FakeCamera, f: Box<FillFn>) -> Box<Box<FillFn>> {
    let mut holder = Box::new(f);
    let data = &mut *holder as *mut Box<FillFn> as *mut c_void;
    let cam: *mut aravis_sys::ArvFakeCamera = camera.to_glib_none().0;
    // SAFETY: `cam` is a live fake camera (we hold a reference); `data` points into the heap
    // allocation of `holder`, which does not move when the box is moved and which the caller
    // keeps until the camera's thread is joined. Aravis swaps the callback under its fill mutex.
    unsafe { aravis_sys::arv_fake_camera_set_fill_pattern(cam, Some(fill_trampoline), data) };
    holder
}
