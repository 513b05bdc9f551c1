//! How a camera is set up: the window, exposure, gain, trigger and the GigE Vision stream's
//! transport settings ([`CameraConfig`], [`StreamOptions`]), and what is known of each frame
//! beyond its pixels ([`FrameMeta`]).

/// When the camera takes a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Trigger {
    /// Free running at the camera's own frame rate (triggers cleared).
    #[default]
    Free,
    /// One software trigger (`TriggerSoftware`) per frame asked for.
    Software,
    /// The hardware line 1 (`TriggerSource = Line1`): the PLC's trigger output.
    Line1,
}

/// The GigE Vision stream's transport settings (ignored for USB3 Vision cameras).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamOptions {
    /// Disable Aravis's packet socket (`PACKET_SOCKET_DISABLED`). The packet socket is faster on a
    /// real network card but sees no packets on loopback: needed for a camera on 127.0.0.1.
    /// Default: true.
    pub packet_socket_disabled: bool,
    /// The stream socket's receive buffer, bytes (fixed; `None`: Aravis sizes it to one frame).
    /// The kernel caps it at `net.core.rmem_max`. Default: 4 MiB (at 1440×540 at 100 frames/s
    /// over loopback, a buffer of one frame lost packets in almost every frame; 4 MiB none).
    pub socket_buffer_bytes: Option<u32>,
    /// Ask the camera to resend lost packets. Default: true.
    pub packet_resend: bool,
    /// Stream buffers queued for the camera (frames in flight). Default: 16.
    pub buffers: u32,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            packet_socket_disabled: true,
            socket_buffer_bytes: Some(4 << 20),
            packet_resend: true,
            buffers: 16,
        }
    }
}

/// The window on the sensor, px (GenICam `OffsetX`, `OffsetY`, `Width`, `Height`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First column, px.
    pub offset_x: u32,
    /// First row, px.
    pub offset_y: u32,
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
}

/// How to set up a camera for the detector.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraConfig {
    /// Width × height of the window, px, centred on the camera's sensor unless
    /// [`window_offset`](Self::window_offset) is given.
    pub window_size: (u32, u32),
    /// The window's offset (`OffsetX`, `OffsetY`), px; `None`: centred on the sensor (rounded
    /// down to the camera's increments).
    pub window_offset: Option<(u32, u32)>,
    /// Exposure time, µs (`ExposureTime`); `None`: the camera's.
    pub exposure_us: Option<f64>,
    /// Gain, dB (`Gain`); `None`: the camera's.
    pub gain_db: Option<f64>,
    /// The trigger.
    pub trigger: Trigger,
    /// GigE Vision packet size, bytes (`GevSCPSPacketSize`); `None`: the camera's.
    pub packet_size: Option<u32>,
    /// The stream's transport settings.
    pub stream: StreamOptions,
    /// How long to wait for a frame before giving up, ms (the camera is then reported gone).
    /// Default: 3000.
    pub frame_timeout_ms: u64,
    /// Hand incomplete frames (lost packets) on, marked in their [`FrameMeta`]; false: leave
    /// them out (they are still counted). Default: false (the station must never see one).
    pub deliver_incomplete: bool,
    /// Stop after this many frame slots (received or missing); `None`: never.
    pub frames: Option<u64>,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            window_size: (1440, 540),
            window_offset: None,
            exposure_us: None,
            gain_db: None,
            trigger: Trigger::Free,
            packet_size: None,
            stream: StreamOptions::default(),
            frame_timeout_ms: 3000,
            deliver_incomplete: false,
            frames: None,
        }
    }
}

/// What the camera said about one frame slot beyond its pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameMeta {
    /// The frame's slot: 0 for the first frame, then one per frame of the camera, received or
    /// missing (the `index` of its [`FrameStamp`](gonio_vision::FrameStamp)).
    pub slot: u64,
    /// The camera's frame id, counted on across the 16-bit wrap ([`crate::FrameIds`]).
    pub frame_id: u64,
    /// The camera's timestamp, ns (on the camera's clock; 0 for a missing frame).
    pub timestamp_ns: u64,
    /// The frame arrived whole.
    pub complete: bool,
    /// When the frame's buffer arrived on the host.
    pub arrival: std::time::Instant,
    /// Frames missing just before this one (their slots are `slot - missing … slot - 1`, their ids
    /// `frame_id - missing … frame_id - 1`, unless a block id 0 was skipped among them).
    pub missing_before: u64,
}

/// What a stream did so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StreamStats {
    /// Frames received (complete or not).
    pub frames: u64,
    /// Frames received whole.
    pub complete: u64,
    /// Frames received with packets missing (or otherwise broken).
    pub incomplete: u64,
    /// Frames missing from the camera's id sequence.
    pub missing: u64,
    /// Packets the camera resent on request.
    pub resent_packets: u64,
    /// Packets lost for good.
    pub missing_packets: u64,
}

impl FrameMeta {
    /// The slots and frame ids of the frames missing just before this one, oldest first. Ids
    /// whose low 16 bits are 0 are passed over (GigE Vision 1 never sends block id 0).
    pub fn missing(&self) -> Vec<(u64, u64)> {
        let mut out = Vec::with_capacity(self.missing_before as usize);
        let mut id = self.frame_id;
        for k in 1..=self.missing_before {
            id = id.saturating_sub(1);
            if id & 0xffff == 0 && id <= 0xffff_ffff {
                id = id.saturating_sub(1);
            }
            out.push((self.slot - k, id));
        }
        out.reverse();
        out
    }
}
