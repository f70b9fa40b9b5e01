//! The document's scene flattened: its nodes (and what they hold) with
//! their world matrices, composed in f64.

use super::bounds;
use super::extensions::LIGHTS;
use glam::{DAffine3, DMat4, DQuat, Vec3};
use gltf::Document;

/// A node (or, in a document without scenes, a bare mesh) to place.
pub(super) struct Instance<'a> {
    pub(super) node: usize,
    pub(super) mesh: Option<gltf::Mesh<'a>>,
    pub(super) camera: Option<usize>,
    /// The `KHR_lights_punctual` light the node holds.
    pub(super) light: Option<usize>,
    pub(super) world: DAffine3,
}

/// The document's scene flattened, depth first in document order; what
/// the nodes' transforms warn of (`node_matrix`) is added to `warnings`,
/// one line each, without the file's name.
pub(super) fn instances<'a>(
    document: &'a Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Instance<'a>>, String> {
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let Some(scene) = scene else {
        return Ok(document
            .meshes()
            .map(|mesh| Instance {
                node: 0,
                mesh: Some(mesh),
                camera: None,
                light: None,
                world: DAffine3::IDENTITY,
            })
            .collect());
    };
    let mut visited = vec![false; document.as_json().nodes.len()];
    let mut out = Vec::new();
    let mut stack: Vec<(gltf::Node, DAffine3)> =
        scene.nodes().map(|n| (n, DAffine3::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let seen = visited
            .get_mut(node.index())
            .ok_or_else(|| format!("node {} does not exist", node.index()))?;
        if std::mem::replace(seen, true) {
            return Err(format!(
                "node {} is reached twice from scene {} (the node hierarchy must be a forest)",
                node.index(),
                scene.index()
            ));
        }
        // Finite: node_matrix checked every number.
        let local = node_matrix(&node, warnings)?;
        let world = parent * DAffine3::from_mat4(local);
        if !world.is_finite() {
            return Err(format!(
                "node {}: the composed world transform is not finite",
                node.index()
            ));
        }
        let light = match node.extension_value(LIGHTS) {
            None => None,
            Some(v) => Some(v.get("light").and_then(|l| l.as_u64()).ok_or_else(|| {
                format!(
                    "nodes[{}].extensions.{LIGHTS}.light {} is not a light index",
                    node.index(),
                    v.get("light").map_or("(missing)".into(), |l| l.to_string())
                )
            })? as usize),
        };
        out.push(Instance {
            node: node.index(),
            mesh: node.mesh(),
            camera: node.camera().map(|c| c.index()),
            light,
            world,
        });
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    Ok(out)
}

/// A node's local transform in f64: its matrix, or its translation,
/// rotation and scale composed in f64 (the hierarchy is composed in f64
/// too, and rounded to f32 only in render space). What glTF 2.0 requires
/// of them ([`bounds::node_transform`]) is checked first; a rotation
/// within that check's tolerance of unit length is normalized, so that
/// the digits a writer rounded to do not scale the mesh (every accepted
/// rotation is, as before the tolerance was widened: one within 10^-3 of
/// unit length loads exactly as it did). One further from unit length
/// than [`bounds::ROTATION_QUIET`] adds a line to `warnings`.
fn node_matrix(node: &gltf::Node, warnings: &mut Vec<String>) -> Result<DMat4, String> {
    let transform = node.transform();
    let named = || bounds::named("node", &format!("nodes[{}]", node.index()), node.name());
    let warning = bounds::node_transform(&transform).map_err(|m| format!("{}.{m}", named()))?;
    if let Some(w) = warning {
        warnings.push(format!("{}.{w}", named()));
    }
    Ok(match transform {
        gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(|x| x as f64)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => DMat4::from_scale_rotation_translation(
            Vec3::from(scale).as_dvec3(),
            DQuat::from_array(rotation.map(|x| x as f64)).normalize(),
            Vec3::from(translation).as_dvec3(),
        ),
    })
}
