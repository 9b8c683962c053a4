//! Files in and out: image formats the core reads and writes, and how it writes
//! them safely. Nothing here knows about paint or rendering.

pub mod atomic;
pub mod exr_write;
pub mod png_write;
