//! Accessors read from the document's buffers: their bytes (strided,
//! sparse), as floats or as indices.

use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Data as BufferData;

/// Largest accessor stored without a buffer view (all zeros, then sparse
/// substitutions), in bytes: beyond it the count is a mistake.
const MAX_VIEWLESS_ACCESSOR_BYTES: usize = 1 << 30;

/// The accessor's elements, tightly packed, with sparse substitutions applied.
fn accessor_bytes(accessor: &gltf::Accessor, buffers: &[BufferData]) -> Result<Vec<u8>, String> {
    let index = accessor.index();
    let elem = accessor.size();
    let count = accessor.count();
    let total = count
        .checked_mul(elem)
        .ok_or_else(|| format!("accessor {index}: {count} elements overflow"))?;
    let mut out = match accessor.view() {
        Some(view) => {
            let data = view_bytes(&view, buffers)?;
            let stride = view.stride().unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "accessor {index}: byteStride {stride} is smaller than its {elem}-byte element"
                ));
            }
            let start = accessor.offset();
            if count > 0 {
                let end = (count - 1)
                    .checked_mul(stride)
                    .and_then(|s| s.checked_add(start))
                    .and_then(|s| s.checked_add(elem));
                if end.is_none_or(|e| e > data.len()) {
                    return Err(format!(
                        "accessor {index}: {count} elements of {elem} bytes (stride {stride}, offset {start}) reach past the end of bufferView {} ({} bytes)",
                        view.index(),
                        data.len()
                    ));
                }
            }
            let mut out = Vec::with_capacity(total);
            for i in 0..count {
                let s = start + i * stride;
                out.extend_from_slice(&data[s..s + elem]);
            }
            out
        }
        None => {
            if total > MAX_VIEWLESS_ACCESSOR_BYTES {
                return Err(format!(
                    "accessor {index}: {count} elements without a bufferView is implausibly many"
                ));
            }
            vec![0; total]
        }
    };
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let isize = indices.index_type().size();
        let idata = view_bytes(&indices.view(), buffers)?;
        let ibytes = n
            .checked_mul(isize)
            .and_then(|len| Some(indices.offset()..indices.offset().checked_add(len)?))
            .and_then(|r| idata.get(r));
        let ibytes = ibytes.ok_or_else(|| {
            format!(
                "accessor {index}: {n} sparse indices reach past the end of bufferView {}",
                indices.view().index()
            )
        })?;
        let values = sparse.values();
        let vdata = view_bytes(&values.view(), buffers)?;
        let vbytes = n
            .checked_mul(elem)
            .and_then(|len| Some(values.offset()..values.offset().checked_add(len)?))
            .and_then(|r| vdata.get(r));
        let vbytes = vbytes.ok_or_else(|| {
            format!(
                "accessor {index}: {n} sparse values reach past the end of bufferView {}",
                values.view().index()
            )
        })?;
        for (k, (ib, vb)) in ibytes
            .chunks_exact(isize)
            .zip(vbytes.chunks_exact(elem))
            .enumerate()
        {
            let target = ib
                .iter()
                .rev()
                .fold(0usize, |acc, &b| acc << 8 | b as usize);
            if target >= count {
                return Err(format!("accessor {index}: sparse index {k} is {target}, out of range for {count} elements"));
            }
            out[target * elem..(target + 1) * elem].copy_from_slice(vb);
        }
    }
    Ok(out)
}

fn view_bytes<'b>(
    view: &gltf::buffer::View,
    buffers: &'b [BufferData],
) -> Result<&'b [u8], String> {
    let buffer = buffers.get(view.buffer().index()).ok_or_else(|| {
        format!(
            "bufferView {}: buffer {} is not loaded",
            view.index(),
            view.buffer().index()
        )
    })?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "bufferView {} reaches past the end of buffer {}",
                view.index(),
                view.buffer().index()
            )
        })
}

/// Reads an accessor of the given shape as floats (normalized integers as
/// the glTF spec maps them to [0, 1] or [-1, 1]).
pub(super) fn read_floats(
    accessor: &gltf::Accessor,
    buffers: &[BufferData],
    what: &str,
    shape: Dimensions,
) -> Result<Vec<f32>, String> {
    if accessor.dimensions() != shape {
        return Err(format!(
            "{what} accessor {} is {:?}, expected {shape:?}",
            accessor.index(),
            accessor.dimensions()
        ));
    }
    let bytes = accessor_bytes(accessor, buffers).map_err(|m| format!("{what}: {m}"))?;
    let normalized = accessor.normalized();
    let size = accessor.data_type().size();
    let component = |c: &[u8]| -> f32 {
        match accessor.data_type() {
            DataType::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
            DataType::U8 if normalized => c[0] as f32 / 255.0,
            DataType::U8 => c[0] as f32,
            DataType::I8 if normalized => (c[0] as i8 as f32 / 127.0).max(-1.0),
            DataType::I8 => c[0] as i8 as f32,
            DataType::U16 if normalized => u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0,
            DataType::U16 => u16::from_le_bytes([c[0], c[1]]) as f32,
            DataType::I16 if normalized => {
                (i16::from_le_bytes([c[0], c[1]]) as f32 / 32767.0).max(-1.0)
            }
            DataType::I16 => i16::from_le_bytes([c[0], c[1]]) as f32,
            DataType::U32 if normalized => {
                (u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64 / u32::MAX as f64) as f32
            }
            DataType::U32 => u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32,
        }
    };
    Ok(bytes.chunks_exact(size).map(component).collect())
}

pub(super) fn read_indices(
    accessor: &gltf::Accessor,
    buffers: &[BufferData],
) -> Result<Vec<u32>, String> {
    let data_type = accessor.data_type();
    if accessor.dimensions() != Dimensions::Scalar
        || !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "indices accessor {} is {:?} of {data_type:?}, expected scalar unsigned integers",
            accessor.index(),
            accessor.dimensions()
        ));
    }
    let bytes = accessor_bytes(accessor, buffers).map_err(|m| format!("indices: {m}"))?;
    Ok(match data_type {
        DataType::U8 => bytes.iter().map(|&b| b as u32).collect(),
        DataType::U16 => bytes
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .collect(),
        _ => bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    })
}
