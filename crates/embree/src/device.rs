//! The Embree device: owns the library instance and turns Embree's error
//! callback into `Result`s.

use std::ffi::{CStr, CString, c_char, c_void};
use std::sync::Mutex;

use super::error::{EmbreeError, code_name};
use super::sys;

/// Configuration passed to `rtcNewDevice`: Embree must stay silent; errors
/// reach the caller as values.
const CONFIG: &CStr = c"verbose=0";

/// An error reported by Embree's callback, waiting to be picked up.
struct Pending {
    code: sys::RTCError,
    message: String,
}

/// Where the callback leaves errors. Boxed so its address, handed to Embree
/// as the callback's user pointer, stays put when `Device` moves.
type ErrorSlot = Mutex<Option<Pending>>;

/// Called by Embree (on any thread, including its build workers) when a call fails.
unsafe extern "C" fn on_error(user: *mut c_void, code: sys::RTCError, message: *const c_char) {
    let message = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string that is valid for the
        // duration of this callback; we copy it out before returning.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    // SAFETY: `user` is the `ErrorSlot` registered in `Device::new`; the box
    // outlives the device's callback registration (Drop unregisters first).
    let slot = unsafe { &*(user as *const ErrorSlot) };
    let mut pending = slot.lock().unwrap_or_else(|e| e.into_inner());
    // The first error since the last check is the cause; later ones are usually
    // consequences of it, so they do not overwrite it.
    if pending.is_none() {
        *pending = Some(Pending { code, message });
    }
}

/// An Embree device (one library instance with its own thread pool and memory).
pub struct Device {
    raw: sys::RTCDevice,
    errors: Box<ErrorSlot>,
    ray_mask_supported: bool,
}

// SAFETY: an `RTCDevice` is a handle to an internally synchronised, reference-
// counted object; Embree documents device calls as thread-safe. The only Rust-
// side state shared with Embree is the error slot, which is a `Mutex`.
unsafe impl Send for Device {}
// SAFETY: as above; `&Device` exposes only thread-safe Embree calls and the mutex.
unsafe impl Sync for Device {}

impl Device {
    /// Creates a device and registers the error callback.
    pub fn new() -> Result<Device, EmbreeError> {
        Self::create(CONFIG)
    }

    /// Creates a device with an Embree configuration string (e.g.
    /// `"threads=2,verbose=0"`, see `rtcNewDevice`). A string Embree rejects
    /// is an `Err`, never a crash.
    pub fn with_config(config: &str) -> Result<Device, EmbreeError> {
        let config = CString::new(config).map_err(|_| EmbreeError::InvalidConfig)?;
        Self::create(&config)
    }

    fn create(config: &CStr) -> Result<Device, EmbreeError> {
        // SAFETY: `config` is a valid NUL-terminated string that Embree only reads.
        let raw = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks Embree for the thread-local error of
            // the failed rtcNewDevice, which is what the docs prescribe.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError::NullHandle {
                call: "rtcNewDevice",
                code_name: code_name(code),
            });
        }
        let errors: Box<ErrorSlot> = Box::new(Mutex::new(None));
        let user = &*errors as *const ErrorSlot as *mut c_void;
        // SAFETY: `raw` is a live device; `on_error` has the callback signature
        // Embree expects and `user` points to the boxed slot, which we keep
        // alive until after the callback is unregistered in Drop.
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(on_error), user) };
        let prop = sys::RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED;
        // SAFETY: `raw` is a live device and this property is read-only.
        let ray_mask_supported = unsafe { sys::rtcGetDeviceProperty(raw, prop) } != 0;
        let device = Device {
            raw,
            errors,
            ray_mask_supported,
        };
        device.check("rtcNewDevice")?;
        Ok(device)
    }

    /// Version of the Embree library linked at run time, e.g. "3.13.5".
    pub fn version() -> String {
        match Device::new() {
            Ok(device) => device.library_version(),
            // Without a device the compile-time header version is the best answer.
            Err(_) => Device::header_version(),
        }
    }

    /// Version of the Embree headers this binary was compiled against, e.g.
    /// "3.13.5". The library loaded at run time must have the same major
    /// version and be at least as new.
    pub fn header_version() -> String {
        format!(
            "{}.{}.{}",
            sys::RTC_VERSION_MAJOR,
            sys::RTC_VERSION_MINOR,
            sys::RTC_VERSION_PATCH
        )
    }

    /// Version of the library behind this device, e.g. "3.13.5".
    pub fn library_version(&self) -> String {
        // SAFETY: `self.raw` is a live device and this property is read-only.
        let v = unsafe { sys::rtcGetDeviceProperty(self.raw, sys::RTC_DEVICE_PROPERTY_VERSION) };
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }

    /// Whether this Embree build honours per-ray masks (Debian's does).
    pub fn ray_mask_supported(&self) -> bool {
        self.ray_mask_supported
    }

    pub(crate) fn raw(&self) -> sys::RTCDevice {
        self.raw
    }

    /// Turns an error the callback recorded since the last check into `Err`.
    /// Errors from concurrent calls on other threads may be attributed to the
    /// wrong call; they are still never lost.
    pub(crate) fn check(&self, during: &'static str) -> Result<(), EmbreeError> {
        let pending = self.errors.lock().unwrap_or_else(|e| e.into_inner()).take();
        match pending {
            None => Ok(()),
            Some(Pending { code, message }) => Err(EmbreeError::Embree {
                code,
                code_name: code_name(code),
                message,
                during,
            }),
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `self.raw` is live. Unregistering first means Embree can no
        // longer call into `self.errors`, which is freed right after this.
        // Every scene borrowed the device, so none is left to use it.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
        }
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("version", &self.library_version())
            .field("ray_mask_supported", &self.ray_mask_supported)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_embree_reports_through_the_callback_comes_back_from_check() {
        let device = Device::new().unwrap();
        // SAFETY: the device is live; an unknown geometry type is an argument
        // Embree checks, reports through the callback and answers with null.
        let geom = unsafe { sys::rtcNewGeometry(device.raw(), 12345 as sys::RTCGeometryType) };
        assert!(geom.is_null());
        match device.check("rtcNewGeometry") {
            Err(EmbreeError::Embree {
                code_name, during, ..
            }) => {
                assert!(code_name.starts_with("RTC_ERROR_"), "{code_name}");
                assert_eq!(during, "rtcNewGeometry");
            }
            other => panic!("expected an Embree error, got {other:?}"),
        }
        // Picked up once: the next check starts clean.
        assert!(device.check("next call").is_ok());
    }
}
