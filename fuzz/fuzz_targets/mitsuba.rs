//! Mitsuba 3 scene files and the mesh and grid files their shapes read
//! (`reference::loader::mitsuba`): the first byte picks the reader (the
//! XML scene, made into a scene; OBJ; PLY; Mitsuba's serialized; with bit
//! 3 set, a `.vol` grid), the rest is the file. Any input gives a scene or
//! an error, never a panic; a mesh read has its indices in range, a grid
//! as many samples as its sizes say.
#![no_main]

use libfuzzer_sys::fuzz_target;
use reference::loader::mitsuba::{meshes, xml};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let opts = meshes::MeshOptions {
        face_normals: which & 4 != 0,
        flip_tex_coords: None,
        shape_index: u32::from(which >> 4),
    };
    if which & 8 != 0 {
        if let Ok(g) = meshes::parse_vol(rest) {
            let n: usize = g.dims.iter().map(|&d| d as usize).product();
            assert_eq!(g.values.len(), n);
        }
        return;
    }
    let mesh = match which % 4 {
        0 => {
            let Ok(text) = std::str::from_utf8(rest) else {
                return;
            };
            // Files the scene names are looked for under a folder that
            // does not exist: their errors, not the disk, are fuzzed.
            let path = Path::new("/nonexistent-twintrace-fuzz/scene.xml");
            if let Ok(doc) = xml::parse_text(text, path, &[]) {
                let _ = reference::loader::mitsuba::build(&doc);
            }
            return;
        }
        1 => meshes::parse_obj(rest, &opts),
        2 => meshes::parse_ply(rest, &opts),
        _ => meshes::parse_serialized(rest, &opts),
    };
    if let Ok(m) = mesh {
        let n = m.positions.len();
        assert!(m.indices.len() % 3 == 0);
        assert!(m.indices.iter().all(|&i| (i as usize) < n));
        assert!(m.normals.as_ref().is_none_or(|v| v.len() == n));
        assert!(m.uvs.as_ref().is_none_or(|v| v.len() == n));
    }
});
