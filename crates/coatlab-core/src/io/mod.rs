//! Files in and out: image formats the core reads and writes, and how it writes
//! them safely. Nothing here knows about paint or rendering.

pub mod atomic;
pub mod exr_read;
pub mod exr_write;
pub mod hdr;
pub mod markup;
pub mod png_write;
pub mod rgb_image;
pub mod tagged;
