//! The wrapper's error type and Embree error-code names.

use super::sys;

/// Everything that can go wrong in the Embree wrapper.
#[derive(Debug, thiserror::Error)]
pub enum EmbreeError {
    /// Embree reported an error through the device error callback.
    #[error("Embree {code_name} ({code}) during {during}: {message}")]
    Embree {
        /// Raw `RTCError` value.
        code: u32,
        /// Its name, e.g. `RTC_ERROR_INVALID_ARGUMENT`.
        code_name: &'static str,
        /// Embree's own message string.
        message: String,
        /// The wrapper call that was running when Embree complained.
        during: &'static str,
    },
    /// Embree returned a null handle without reporting anything through the callback.
    #[error("Embree returned a null handle from {call} ({code_name})")]
    NullHandle {
        /// The Embree function that failed.
        call: &'static str,
        /// Name of the error code Embree reported, if any.
        code_name: &'static str,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {triangle} refers to vertex {index}, but the mesh has only {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// Index of the offending triangle.
        triangle: usize,
        /// The out-of-range vertex index.
        index: u32,
        /// Number of vertices passed in.
        vertex_count: usize,
    },
    /// A vertex position is NaN or infinite; Embree's BVH builder would produce garbage bounds.
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition {
        /// Index of the offending vertex.
        vertex: usize,
        /// Its value.
        position: [f32; 3],
    },
    /// A device configuration string with a NUL byte inside, which the C API
    /// cannot be given.
    #[error("the Embree configuration string contains a NUL byte")]
    InvalidConfig,
    /// The Embree build lacks a feature the requested configuration needs.
    #[error("this Embree build does not support {0}")]
    Unsupported(&'static str),
    /// More vertices or triangles than Embree's 32-bit counts allow.
    #[error("mesh too large for Embree: {count} {what}")]
    TooLarge {
        /// "vertices" or "triangles".
        what: &'static str,
        /// The count passed in.
        count: usize,
    },
}

/// Embree's name for an `RTCError` code; unknown codes (newer Embree) get a generic name.
pub(crate) fn code_name(code: sys::RTCError) -> &'static str {
    match code {
        sys::RTC_ERROR_NONE => "RTC_ERROR_NONE",
        sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
        sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
        sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
        sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
        sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
        sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
        _ => "RTC_ERROR_(unrecognised code)",
    }
}
