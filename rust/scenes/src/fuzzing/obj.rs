//! The `obj` target: arbitrary bytes as an OBJ file.

use super::{check, limits};
use crate::import::load_obj;

/// Reads `data` as an OBJ: refused with an error naming the file, or a valid framed scene
/// within the limits. Never panics.
pub fn obj(data: &[u8]) {
    check("fuzz.obj", load_obj("fuzz.obj", data, 2, &limits()));
}
