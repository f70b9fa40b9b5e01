//! A glTF document read and checked: [`GltfFile`] (the JSON or GLB parsed,
//! its buffers loaded), error locations, URIs and buffer views.

use super::bounds;
use super::extensions::{check_required, SUPPORTED_EXTENSIONS};
use crate::error::SceneError;
use gltf::buffer::Data as BufferData;
use gltf::mesh::Semantic;
use gltf::Document;
use std::path::{Path, PathBuf};

/// A parsed document with its buffers loaded.
pub(super) struct GltfFile {
    pub(super) path: PathBuf,
    /// The document and the files of its external buffers, as read.
    pub(super) files: Vec<PathBuf>,
    pub(super) base: PathBuf,
    pub(super) document: Document,
    pub(super) buffers: Vec<BufferData>,
    /// Extensions the document uses (without requiring them) that the
    /// importer ignores.
    pub(super) ignored_extensions: Vec<String>,
}

impl GltfFile {
    pub(super) fn open(path: &Path) -> Result<Self, SceneError> {
        Self::open_from(path, None)
    }

    /// The document `path`, or `bytes` if given (named `path`).
    pub(super) fn open_from(path: &Path, bytes: Option<&[u8]>) -> Result<Self, SceneError> {
        let fail = |message: String| SceneError::Io {
            path: path.to_path_buf(),
            message,
        };
        let read;
        let bytes = match bytes {
            Some(bytes) => bytes,
            None => {
                read =
                    std::fs::read(path).map_err(|e| fail(format!("cannot read glTF file: {e}")))?;
                &read
            }
        };
        if bytes.starts_with(b"glTF") {
            check_glb_header(bytes).map_err(|m| fail(format!("not a valid GLB file: {m}")))?;
        }
        let (document, mut blob) =
            parse(bytes).map_err(|m| fail(format!("cannot read glTF: {m}")))?;
        let mut json = document.into_json();
        // The required list is checked here, against what this importer
        // implements; the `gltf` crate's validation would refuse every
        // name outside its own enabled features (`KHR_lights_punctual`,
        // `KHR_materials_volume` and `KHR_materials_clearcoat` among
        // them), so it runs without the list, which is then put back.
        // Nothing else in that validation reads the list.
        let required = std::mem::take(&mut json.extensions_required);
        check_required(&required).map_err(&fail)?;
        let document = Document::from_json_without_validation(json);
        check_position_accessors(&document).map_err(&fail)?;
        let mut json = Document::from_json(document.into_json())
            .map_err(|e| fail(format!("cannot read glTF: {e}")))?
            .into_json();
        json.extensions_required = required;
        let document = Document::from_json_without_validation(json);
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let ignored_extensions = document
            .extensions_used()
            .filter(|n| !SUPPORTED_EXTENSIONS.contains(n))
            .map(str::to_string)
            .collect();
        check_uris(&document).map_err(&fail)?;
        check_views(&document).map_err(&fail)?;
        let mut buffers = Vec::new();
        let mut files = vec![path.to_path_buf()];
        for buffer in document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = buffer.source() {
                files.extend(uri_file(&base, uri));
            }
            let source = match buffer.source() {
                gltf::buffer::Source::Bin => "the GLB binary chunk".to_string(),
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                    "its data: URI".to_string()
                }
                gltf::buffer::Source::Uri(uri) => format!("`{}`", base.join(uri).display()),
            };
            let data = BufferData::from_source_and_blob(buffer.source(), Some(&base), &mut blob)
                .map_err(|e| {
                    fail(format!(
                        "cannot load buffer {} from {source}: {e}",
                        buffer.index()
                    ))
                })?;
            if data.len() < buffer.length() {
                return Err(fail(format!(
                    "buffer {} from {source} holds {} bytes, the document says {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )));
            }
            buffers.push(data);
        }
        Ok(Self {
            path: path.to_path_buf(),
            files,
            base,
            document,
            buffers,
            ignored_extensions,
        })
    }

    pub(super) fn error(&self, message: String) -> SceneError {
        SceneError::Io {
            path: self.path.clone(),
            message,
        }
    }
}

/// The document's JSON (a `.gltf`, or a `.glb`'s JSON chunk) as the
/// `gltf` crate's types, unvalidated, and the `.glb`'s binary chunk. It is
/// deserialized as the crate does, through `serde_path_to_error`, so that
/// a value of the wrong type is named by its path in the file.
fn parse(bytes: &[u8]) -> Result<(Document, Option<Vec<u8>>), String> {
    let glb;
    let (json, blob) = if bytes.starts_with(b"glTF") {
        glb = gltf::Glb::from_slice(bytes).map_err(|e| e.to_string())?;
        (&*glb.json, glb.bin.as_deref().map(<[u8]>::to_vec))
    } else {
        (bytes, None)
    };
    let de = &mut serde_json::Deserializer::from_slice(json);
    let root: gltf::json::Root =
        serde_path_to_error::deserialize(&mut *de).map_err(|e| match e.path().iter().next() {
            // Not in a value (a syntax error before the first member).
            None => e.inner().to_string(),
            Some(_) => format!("{}: {}", path_named(e.path(), json), e.inner()),
        })?;
    de.end().map_err(|e| e.to_string())?;
    Ok((Document::from_json_without_validation(root), blob))
}

/// A path in the document (`materials[0].pbrMetallicRoughness...`), the
/// element of the top-level array it starts in [`bounds::named`] as the
/// importer's other errors name it (`material "Brass", materials[0]:
/// pbrMetallicRoughness...`) where the element has a name.
fn path_named(path: &serde_path_to_error::Path, json: &[u8]) -> String {
    use serde_path_to_error::Segment;
    let segments: Vec<&Segment> = path.iter().collect();
    let [Segment::Map { key }, Segment::Seq { index }, rest @ ..] = segments.as_slice() else {
        return path.to_string();
    };
    let what = match key.as_str() {
        "accessors" => "accessor",
        "bufferViews" => "bufferView",
        "buffers" => "buffer",
        "cameras" => "camera",
        "images" => "image",
        "materials" => "material",
        "meshes" => "mesh",
        "nodes" => "node",
        "samplers" => "sampler",
        "scenes" => "scene",
        "textures" => "texture",
        _ => return path.to_string(),
    };
    let name = element_name(json, key, *index);
    let mut inside = String::new();
    for segment in rest {
        match segment {
            Segment::Seq { index } => inside += &format!("[{index}]"),
            Segment::Map { key } if inside.is_empty() => inside += key,
            Segment::Map { key } => inside += &format!(".{key}"),
            Segment::Enum { variant } if inside.is_empty() => inside += variant,
            Segment::Enum { variant } => inside += &format!(".{variant}"),
            Segment::Unknown => inside += "?",
        }
    }
    let element = bounds::named(what, &format!("{key}[{index}]"), name.as_deref());
    if inside.is_empty() {
        element
    } else {
        format!("{element}: {inside}")
    }
}

/// The `name` of element `index` of the document's top-level array `key`,
/// read from a document that did not deserialize: everything but the
/// names is skipped unparsed (serde_json skips a number without reading
/// its value, so one beyond f64's range does not stop it).
fn element_name(json: &[u8], key: &str, index: usize) -> Option<String> {
    #[derive(serde::Deserialize)]
    struct Element {
        name: Option<String>,
    }
    #[derive(Default, serde::Deserialize)]
    #[serde(default, rename_all = "camelCase")]
    struct Arrays {
        accessors: Vec<Element>,
        buffer_views: Vec<Element>,
        buffers: Vec<Element>,
        cameras: Vec<Element>,
        images: Vec<Element>,
        materials: Vec<Element>,
        meshes: Vec<Element>,
        nodes: Vec<Element>,
        samplers: Vec<Element>,
        scenes: Vec<Element>,
        textures: Vec<Element>,
    }
    let arrays: Arrays = serde_json::from_slice(json).ok()?;
    let elements = match key {
        "accessors" => arrays.accessors,
        "bufferViews" => arrays.buffer_views,
        "buffers" => arrays.buffers,
        "cameras" => arrays.cameras,
        "images" => arrays.images,
        "materials" => arrays.materials,
        "meshes" => arrays.meshes,
        "nodes" => arrays.nodes,
        "samplers" => arrays.samplers,
        "scenes" => arrays.scenes,
        "textures" => arrays.textures,
        _ => return None,
    };
    elements.into_iter().nth(index)?.name
}

/// Checks what the `gltf` crate's GLB parser takes on trust.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    let word = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err("the 12-byte header is truncated".into());
    };
    if version != 2 {
        return Err(format!("container version {version} (only 2 is supported)"));
    }
    if (length as usize) < 20 || length as usize > bytes.len() {
        return Err(format!(
            "the header states {length} bytes but the file has {} (at least 20 are needed)",
            bytes.len()
        ));
    }
    Ok(())
}

/// The `gltf` crate's validation indexes the accessor a primitive's
/// `POSITION` names before it checks the index (it panicked on a file
/// whose `accessors` were misspelled; found by the fuzz target `glb`).
fn check_position_accessors(document: &Document) -> Result<(), String> {
    let json = document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= json.accessors.len() {
                    return Err(format!(
                        "mesh {m} primitive {p}: POSITION names accessor {}, the file has {}",
                        index.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The `gltf` crate unwraps the UTF-8 decoding of percent-escaped relative
/// URIs; reject those that would not decode.
fn check_uris(document: &Document) -> Result<(), String> {
    let json = document.as_json();
    let buffer_uris = json
        .buffers
        .iter()
        .enumerate()
        .filter_map(|(i, b)| b.uri.as_deref().map(|u| (format!("buffer {i}"), u)));
    let image_uris = json
        .images
        .iter()
        .enumerate()
        .filter_map(|(i, im)| im.uri.as_deref().map(|u| (format!("image {i}"), u)));
    for (what, uri) in buffer_uris.chain(image_uris) {
        if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
            return Err(format!(
                "{what}: URI `{uri}` is not valid UTF-8 once percent-decoded"
            ));
        }
    }
    Ok(())
}

fn percent_decodes_to_utf8(uri: &str) -> bool {
    percent_decode(uri).is_some()
}

/// `uri` with its `%XX` escapes decoded, if that is UTF-8 (as the `gltf`
/// crate decodes a relative URI before reading it).
fn percent_decode(uri: &str) -> Option<String> {
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            if let (Some(h), Some(l)) = (
                bytes.get(i + 1).and_then(|&c| hex(c)),
                bytes.get(i + 2).and_then(|&c| hex(c)),
            ) {
                out.push(h << 4 | l);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8(out).ok()
}

/// The file a buffer or image URI names, as the `gltf` crate resolves it
/// (a relative URI, percent-decoded, against `base`; `file:` as written);
/// `None` for a `data:` URI or a scheme the crate does not read.
pub(super) fn uri_file(base: &Path, uri: &str) -> Option<PathBuf> {
    if uri.contains(':') {
        let rest = uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))?;
        return Some(PathBuf::from(rest));
    }
    percent_decode(uri).map(|p| base.join(p))
}

/// Every buffer view must lie inside its buffer (the image decoder slices
/// views without checking).
fn check_views(document: &Document) -> Result<(), String> {
    for view in document.views() {
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|e| e > view.buffer().length()) {
            return Err(format!(
                "bufferView {} (offset {}, length {}) reaches past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                view.buffer().length()
            ));
        }
    }
    Ok(())
}
