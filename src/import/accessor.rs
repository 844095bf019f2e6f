//! Accessor decoding with every offset and length checked against the buffer before it is read:
//! strided views, all component types, normalized integers and sparse substitution.

use gltf_json as json;
use json::accessor::{ComponentType, Type};
use json::validation::Checked;

use super::ImportError;
use super::document::Document;

/// Most elements one accessor may declare; far beyond any tree, small enough to allocate.
const MAX_COUNT: u64 = 1 << 24;

/// Values of an accessor, `components` per element, converted to `f64` (exact for every glTF
/// component type, including `UNSIGNED_INT` indices).
#[derive(Debug)]
pub(super) struct Values {
    pub components: usize,
    pub data: Vec<f64>,
}

impl Values {
    pub fn count(&self) -> usize {
        self.data.len() / self.components.max(1)
    }

    pub fn element(&self, i: usize) -> &[f64] {
        &self.data[i * self.components..(i + 1) * self.components]
    }
}

fn component_size(ct: ComponentType) -> usize {
    match ct {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn decode(ct: ComponentType, normalized: bool, b: &[u8]) -> f64 {
    // Normalized integers map to [0, 1] or [-1, 1] as glTF 2.0 section 3.11 specifies.
    match ct {
        ComponentType::I8 => {
            let v = b[0] as i8 as f64;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        ComponentType::U8 => {
            let v = b[0] as f64;
            if normalized { v / 255.0 } else { v }
        }
        ComponentType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        ComponentType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized { v / 65535.0 } else { v }
        }
        ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// A checked window of a buffer view: `count` elements of `elem` bytes every `stride` bytes,
/// starting `offset` bytes into the view. The window returned starts at the first element, so
/// element `i` is at `i * stride`.
fn view_window<'a>(
    doc: &'a mut Document,
    view_index: usize,
    offset: u64,
    count: u64,
    elem: usize,
    stride: Option<usize>,
    field: &str,
) -> Result<(&'a [u8], usize), ImportError> {
    let path = doc.path.clone();
    let Some(view) = doc.root.buffer_views.get(view_index) else {
        return Err(ImportError::invalid(
            &path,
            field,
            format!("bufferView {view_index} does not exist"),
        ));
    };
    let view_offset = view.byte_offset.map_or(0, |o| o.0);
    let view_length = view.byte_length.0;
    let stride = stride.unwrap_or_else(|| view.byte_stride.map_or(elem, |s| s.0));
    if stride < elem {
        return Err(ImportError::invalid(
            &path,
            format!("bufferViews[{view_index}].byteStride"),
            format!("stride {stride} is smaller than the element size {elem}"),
        ));
    }
    let buffer_index = view.buffer.value();
    // Bytes of the view the accessor spans, from the view's start: its offset, then every
    // element but the last at the stride, then the last element itself.
    let span = if count == 0 {
        0
    } else {
        (count - 1)
            .checked_mul(stride as u64)
            .and_then(|s| s.checked_add(elem as u64))
            .unwrap_or(u64::MAX)
    };
    let needed = offset.saturating_add(span);
    if needed > view_length {
        return Err(ImportError::invalid(
            &path,
            field,
            format!(
                "reads bytes {offset} to {needed} of bufferView {view_index}, which has only {view_length}"
            ),
        ));
    }
    let buffer = doc.buffer(buffer_index, &format!("bufferViews[{view_index}].buffer"))?;
    let end = view_offset.saturating_add(view_length);
    if end > buffer.len() as u64 {
        return Err(ImportError::invalid(
            &path,
            format!("bufferViews[{view_index}]"),
            format!(
                "ends at byte {end} but buffer {buffer_index} has {}",
                buffer.len()
            ),
        ));
    }
    // Both ends lie within the view, which lies within the buffer.
    let start = (view_offset + offset) as usize;
    Ok((&buffer[start..start + span as usize], stride))
}

/// Reads accessor `index` as floating-point values; `field` names the referencing JSON path.
pub(super) fn read(doc: &mut Document, index: usize, field: &str) -> Result<Values, ImportError> {
    let path = doc.path.clone();
    let here = format!("accessors[{index}]");
    let Some(accessor) = doc.root.accessors.get(index) else {
        return Err(ImportError::invalid(
            &path,
            field,
            format!(
                "accessor {index} does not exist ({} accessors)",
                doc.root.accessors.len()
            ),
        ));
    };
    let Checked::Valid(json::accessor::GenericComponentType(ct)) = accessor.component_type else {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.componentType"),
            "invalid",
        ));
    };
    let components = match accessor.type_ {
        Checked::Valid(Type::Scalar) => 1,
        Checked::Valid(Type::Vec2) => 2,
        Checked::Valid(Type::Vec3) => 3,
        Checked::Valid(Type::Vec4) => 4,
        Checked::Valid(_) => {
            return Err(ImportError::unsupported(
                &path,
                format!("{here}.type"),
                "matrix accessors",
            ));
        }
        Checked::Invalid => {
            return Err(ImportError::invalid(
                &path,
                format!("{here}.type"),
                "invalid",
            ));
        }
    };
    let count = accessor.count.0;
    if count == 0 {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.count"),
            "0: an accessor holds at least one element (glTF's minimum is 1)",
        ));
    }
    if count > MAX_COUNT {
        return Err(ImportError::unsupported(
            &path,
            format!("{here}.count"),
            format!("{count} elements is more than the {MAX_COUNT} we accept"),
        ));
    }
    let normalized = accessor.normalized;
    let offset = accessor.byte_offset.map_or(0, |o| o.0);
    let view = accessor.buffer_view.map(|v| v.value());
    let sparse = accessor.sparse.clone();
    let csize = component_size(ct);
    let elem = csize * components;

    let mut data = Vec::new();
    if let Some(view) = view {
        if offset % csize as u64 != 0 {
            doc.warn(format!(
                "{}: {here}.byteOffset {offset} is not a multiple of the component size",
                path.display()
            ));
        }
        let (bytes, stride) = view_window(
            doc,
            view,
            offset,
            count,
            elem,
            None,
            &format!("{field} ({here})"),
        )?;
        data.reserve_exact(count as usize * components);
        for i in 0..count as usize {
            for c in 0..components {
                let at = i * stride + c * csize;
                data.push(decode(ct, normalized, &bytes[at..at + csize]));
            }
        }
    } else {
        let values = count * components as u64;
        doc.unbacked_values += values;
        if doc.unbacked_values > super::document::MAX_UNBACKED_VALUES {
            return Err(ImportError::unsupported(
                &path,
                format!("{field} ({here})"),
                format!(
                    "has no bufferView, so its {count} elements are zeros: with the file's other such accessors, more than the {} values we decode without bytes to stand for them",
                    super::document::MAX_UNBACKED_VALUES
                ),
            ));
        }
        data = vec![0.0; values as usize];
    }

    if let Some(sparse) = sparse {
        let element = Element {
            ct,
            normalized,
            components,
        };
        substitute(doc, &here, &sparse, count, element, &mut data)?;
    }
    Ok(Values { components, data })
}

/// How an accessor's elements are stored.
#[derive(Clone, Copy)]
struct Element {
    ct: ComponentType,
    normalized: bool,
    components: usize,
}

/// Applies accessor `here`'s sparse substitutions to its `count` elements in `data`.
fn substitute(
    doc: &mut Document,
    here: &str,
    sparse: &json::accessor::sparse::Sparse,
    count: u64,
    element: Element,
    data: &mut [f64],
) -> Result<(), ImportError> {
    let path = doc.path.clone();
    let Element {
        ct,
        normalized,
        components,
    } = element;
    let csize = component_size(ct);
    let elem = csize * components;
    let n = sparse.count.0;
    if n > count {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.sparse.count"),
            format!("{n} substitutions for {count} elements"),
        ));
    }
    let Checked::Valid(json::accessor::IndexComponentType(ict)) = sparse.indices.component_type
    else {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.sparse.indices.componentType"),
            "invalid",
        ));
    };
    let isize_ = component_size(ict);
    let (ibytes, _) = view_window(
        doc,
        sparse.indices.buffer_view.value(),
        sparse.indices.byte_offset.0,
        n,
        isize_,
        Some(isize_),
        &format!("{here}.sparse.indices"),
    )?;
    let targets: Vec<u64> = (0..n as usize)
        .map(|i| decode(ict, false, &ibytes[i * isize_..(i + 1) * isize_]) as u64)
        .collect();
    let (vbytes, _) = view_window(
        doc,
        sparse.values.buffer_view.value(),
        sparse.values.byte_offset.0,
        n,
        elem,
        Some(elem),
        &format!("{here}.sparse.values"),
    )?;
    for (k, &target) in targets.iter().enumerate() {
        if target >= count {
            return Err(ImportError::invalid(
                &path,
                format!("{here}.sparse.indices"),
                format!("index {target} is out of range for {count} elements"),
            ));
        }
        // The spec requires strictly increasing indices: with a repeat, which value stands
        // would be the reader's choice, not the file's.
        if k > 0 && target <= targets[k - 1] {
            return Err(ImportError::invalid(
                &path,
                format!("{here}.sparse.indices"),
                format!(
                    "index {target} (substitution {k}) does not follow {} (substitution {}): \
                     indices must strictly increase",
                    targets[k - 1],
                    k - 1
                ),
            ));
        }
        for c in 0..components {
            let at = k * elem + c * csize;
            data[target as usize * components + c] =
                decode(ct, normalized, &vbytes[at..at + csize]);
        }
    }
    Ok(())
}

/// Reads an index accessor: a scalar of unsigned bytes, shorts or ints.
pub(super) fn read_indices(
    doc: &mut Document,
    index: usize,
    field: &str,
) -> Result<Vec<u32>, ImportError> {
    let path = doc.path.clone();
    if let Some(accessor) = doc.root.accessors.get(index) {
        let is_index_type = matches!(
            accessor.component_type,
            Checked::Valid(json::accessor::GenericComponentType(
                ComponentType::U8 | ComponentType::U16 | ComponentType::U32
            ))
        );
        if !is_index_type || accessor.type_ != Checked::Valid(Type::Scalar) || accessor.normalized {
            return Err(ImportError::invalid(
                &path,
                field,
                format!("accessor {index} is not a scalar of unsigned integers"),
            ));
        }
    }
    let values = read(doc, index, field)?;
    Ok(values.data.iter().map(|&v| v as u32).collect())
}

#[cfg(test)]
mod tests;
