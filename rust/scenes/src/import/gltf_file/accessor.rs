//! glTF accessors checked before they are read: type and component type for their use, no
//! `normalized` flag, offsets aligned, stride and every element (sparse ones too) inside the
//! buffer view, the view inside its buffer's bytes. The `gltf` crate's reader trusts all of
//! this (an index accessor of FLOAT reaches its `unreachable!`), so it is not used.

use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;
use gltf::json::Root;

/// What an accessor is read as: each allows one element type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Use {
    Position,
    Normal,
    Indices,
}

impl Use {
    fn name(self) -> &'static str {
        match self {
            Use::Position => "POSITION",
            Use::Normal => "NORMAL",
            Use::Indices => "indices",
        }
    }

    fn element(self) -> Type {
        match self {
            Use::Position | Use::Normal => Type::Vec3,
            Use::Indices => Type::Scalar,
        }
    }

    fn accepts(self, component: ComponentType) -> bool {
        match self {
            Use::Position | Use::Normal => component == ComponentType::F32,
            Use::Indices => matches!(
                component,
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            ),
        }
    }

    fn expected(self) -> &'static str {
        match self {
            Use::Position | Use::Normal => "FLOAT (5126)",
            Use::Indices => "UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT (5121, 5123, 5125)",
        }
    }
}

/// The document's accessors over its loaded buffers (each cut to its `byteLength`).
pub(super) struct Accessors<'a> {
    pub root: &'a Root,
    pub buffers: &'a [&'a [u8]],
}

/// Where a checked run of elements lies: `count` elements of `size` bytes, every `stride`
/// bytes from `offset` in `bytes`.
struct Run<'a> {
    bytes: &'a [u8],
    offset: usize,
    stride: usize,
    component: ComponentType,
}

impl Run<'_> {
    /// Component `c` of element `k` as raw bits (a float's bits, an integer's value).
    fn get(&self, k: usize, c: usize) -> u32 {
        let at = self.offset + k * self.stride + c * self.component.size();
        let b = &self.bytes[at..at + self.component.size()];
        match b {
            [x] => *x as u32,
            [x, y] => u16::from_le_bytes([*x, *y]) as u32,
            [x, y, z, w] => u32::from_le_bytes([*x, *y, *z, *w]),
            _ => 0,
        }
    }
}

impl<'a> Accessors<'a> {
    /// The element count of accessor `index` (for the limits, before anything is read).
    pub fn count(&self, index: usize) -> Result<u64, String> {
        let accessor = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| format!("accessor {index} does not exist"))?;
        Ok(accessor.count.0)
    }

    /// Accessor `index` as `use_` reads it, each element as `N` components of raw bits;
    /// everything checked before the output is allocated.
    pub fn read<const N: usize>(&self, index: usize, use_: Use) -> Result<Vec<[u32; N]>, String> {
        let what = format!("accessor {index} ({})", use_.name());
        let accessor = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| format!("{what} does not exist"))?;
        match accessor.type_ {
            Checked::Valid(t) if t == use_.element() && t.multiplicity() == N => {}
            _ => {
                return Err(format!(
                    "{what}: type must be {}",
                    if N == 1 { "SCALAR" } else { "VEC3" }
                ))
            }
        }
        let component = match accessor.component_type {
            Checked::Valid(c) if use_.accepts(c.0) => c.0,
            Checked::Valid(c) => {
                return Err(format!(
                    "{what}: componentType {} is not read here (expected {})",
                    c.0.as_gl_enum(),
                    use_.expected()
                ))
            }
            Checked::Invalid => return Err(format!("{what}: componentType is not valid")),
        };
        if accessor.normalized {
            return Err(format!(
                "{what}: normalized must not be set for {}",
                use_.name()
            ));
        }
        let count = usize::try_from(accessor.count.0)
            .map_err(|_| format!("{what}: count {} is too large", accessor.count.0))?;
        let offset = accessor.byte_offset.map_or(0, |o| o.0);
        let mut out = match accessor.buffer_view {
            Some(view) => {
                let run = self.run(&what, view.value(), offset, count, component, N, true)?;
                (0..count)
                    .map(|k| std::array::from_fn(|c| run.get(k, c)))
                    .collect()
            }
            // No view: zeros, then the sparse values if any (the caller has checked `count`).
            None => vec![[0u32; N]; count],
        };
        if let Some(sparse) = &accessor.sparse {
            let what = format!("{what}: sparse");
            let n = usize::try_from(sparse.count.0)
                .ok()
                .filter(|&n| n <= count)
                .ok_or_else(|| {
                    format!(
                        "{what}: count {} is over the accessor's {count}",
                        sparse.count.0
                    )
                })?;
            let index_type = match sparse.indices.component_type {
                Checked::Valid(c) if Use::Indices.accepts(c.0) => c.0,
                _ => return Err(format!("{what}: indices.componentType is not valid")),
            };
            let indices = self.run(
                &format!("{what} indices"),
                sparse.indices.buffer_view.value(),
                sparse.indices.byte_offset.0,
                n,
                index_type,
                1,
                false,
            )?;
            let values = self.run(
                &format!("{what} values"),
                sparse.values.buffer_view.value(),
                sparse.values.byte_offset.0,
                n,
                component,
                N,
                false,
            )?;
            let mut previous = None;
            for k in 0..n {
                let i = indices.get(k, 0) as usize;
                // The spec asks for strictly increasing indices; that also rules out repeats.
                if i >= count || previous.is_some_and(|p| i <= p) {
                    return Err(format!(
                        "{what}: index #{k} is past the accessor's {count} elements or not \
                         above the one before"
                    ));
                }
                previous = Some(i);
                out[i] = std::array::from_fn(|c| values.get(k, c));
            }
        }
        Ok(out)
    }

    /// Checks that `count` elements of `n` components from `offset` fit in buffer view `view`
    /// (with its stride if `strided`, else tightly packed) and the view in its buffer.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        what: &str,
        view: usize,
        offset: u64,
        count: usize,
        component: ComponentType,
        n: usize,
        strided: bool,
    ) -> Result<Run<'a>, String> {
        let json = self
            .root
            .buffer_views
            .get(view)
            .ok_or_else(|| format!("{what}: bufferView {view} does not exist"))?;
        let buffer = json.buffer.value();
        let data = self
            .buffers
            .get(buffer)
            .ok_or_else(|| format!("bufferView {view}: buffer {buffer} does not exist"))?;
        let start = json.byte_offset.map_or(0, |o| o.0);
        let end = start
            .checked_add(json.byte_length.0)
            .filter(|&end| end <= data.len() as u64)
            .ok_or_else(|| {
                format!(
                    "bufferView {view}: byteOffset {start} + byteLength {} runs past the end \
                     of buffer {buffer} ({} bytes)",
                    json.byte_length.0,
                    data.len()
                )
            })?;
        let bytes = &data[start as usize..end as usize];
        let size = (component.size() * n) as u64;
        let stride = match json.byte_stride {
            Some(s) if strided && s.0 != 0 => s.0 as u64,
            _ => size,
        };
        if stride < size || !stride.is_multiple_of(component.size() as u64) {
            return Err(format!(
                "{what}: bufferView {view}'s byteStride {stride} is under the element's {size} \
                 bytes or not a multiple of its component's"
            ));
        }
        if !offset.is_multiple_of(component.size() as u64) {
            return Err(format!(
                "{what}: byteOffset {offset} is not a multiple of the component size {}",
                component.size()
            ));
        }
        // The last element's end: offset + stride * (count - 1) + size.
        let last = match count {
            0 => Some(offset),
            _ => (count as u64 - 1)
                .checked_mul(stride)
                .and_then(|s| s.checked_add(offset))
                .and_then(|s| s.checked_add(size)),
        };
        if last.is_none_or(|last| last > bytes.len() as u64) {
            return Err(format!(
                "{what}: {count} elements of {size} bytes every {stride} from byteOffset \
                 {offset} run past the end of bufferView {view} ({} bytes)",
                bytes.len()
            ));
        }
        Ok(Run {
            bytes,
            offset: offset as usize,
            stride: stride as usize,
            component,
        })
    }
}
