//! How the GPU walks the scene's primitives (issue: GPU variants,
//! traversal): the binary BVH as the reference builds it (the baseline),
//! a four-wide view of the same tree, a compressed eight-wide one
//! (`crate::compressed`), or one leaf holding every primitive (brute
//! force). All four test the same primitives with the same
//! admits rule and keep the closest hit, ties in t to the smaller
//! primitive id, so a box only decides what is skipped: the hit records
//! are the same bits whatever the walk (`twintrace::twins::traversal`
//! checks it on every scene).
//!
//! The wide records live in the `nodes` binding, as [`BvhNode`]s: record 0
//! is the binary root (its box starts every walk), then wide node `w` is
//! records `1 + 4w .. 1 + 4w + 4`, one lane each. A lane is a binary node
//! with its box bit for bit: an interior lane's `index` is the wide node
//! made of its subtree's top, a leaf lane's is the binary leaf's first
//! entry (`meta` as in the binary tree); unused lanes come last and have
//! `meta` [`WIDE_EMPTY`]. The walk tests a node's four lanes, enters the
//! nearest and stacks the others, leaf lanes as [`WIDE_LEAF_ENTRY`] with
//! their record index. The collapse is the greedy one of Wald et al.,
//! "Getting Rid of Packets" (2008): a node's two children, then the
//! interior lane of largest surface area opened into its two children
//! while lanes remain (the CPU reference's 8-wide view is planned by a
//! cost model instead; the GPU's lanes need no such plan to be exact).
//!
//! The compressed records follow the binary root's record (its exact
//! box) in the same binding, five words a node ([`compressed_words`]).
//!
//! The walk and the layouts themselves ([`Traversal`], [`NodeLayout`],
//! [`LeafLayout`]) and the constants that pass them to the kernels are
//! variant axes, defined in `crate::variants` and re-exported here; the
//! inline entries are made from the packed records by
//! `scene_buffers::inline_entries`.

use crate::compressed::{CompressedNode, Rounding};
use reference::bvh::{BvhNode, BVH_STACK_SIZE};
use reference::Scene;

pub use crate::variants::{
    LeafLayout, NodeLayout, Traversal, LEAVES_CONSTANT, LEAVES_INDEXED, LEAVES_INLINE,
    LEAVES_INLINE_SOA, NODE_LAYOUT_AOS, NODE_LAYOUT_CONSTANT, NODE_LAYOUT_SOA, TRAVERSAL_BINARY,
    TRAVERSAL_COMPRESSED, TRAVERSAL_CONSTANT, TRAVERSAL_WIDE,
};

/// Lanes of a wide node.
pub const WIDE_LANES: usize = 4;

/// `meta` of an unused lane. Its low bits are those of a leaf, so the walk
/// tests for it before anything else.
pub const WIDE_EMPTY: u32 = u32::MAX;

/// The bit that marks a leaf lane on the four-wide walk's stack (the rest
/// is the lane's record index): records number fewer than 2^31
/// ([`wide_records`] refuses more).
pub const WIDE_LEAF_ENTRY: u32 = 1 << 31;

/// The words of `records` as `layout` holds them.
pub fn node_words(records: &[BvhNode], layout: NodeLayout) -> Vec<[u32; 4]> {
    let lo = |n: &BvhNode| {
        [
            n.min[0].to_bits(),
            n.min[1].to_bits(),
            n.min[2].to_bits(),
            n.index,
        ]
    };
    let hi = |n: &BvhNode| {
        [
            n.max[0].to_bits(),
            n.max[1].to_bits(),
            n.max[2].to_bits(),
            n.meta,
        ]
    };
    match layout {
        NodeLayout::Aos => records.iter().flat_map(|n| [lo(n), hi(n)]).collect(),
        NodeLayout::Soa => records
            .iter()
            .map(lo)
            .chain(records.iter().map(hi))
            .collect(),
    }
}

/// The `nodes` binding's words of the compressed walk: `root`'s record
/// (the binary root: its exact box), then the nodes' five words each
/// ([`CompressedNode::words`]), side by side ([`NodeLayout::Aos`]) or
/// word `k` of node `i` at `k · n + i` after the root ([`NodeLayout::Soa`]).
pub fn compressed_words(
    root: &BvhNode,
    nodes: &[CompressedNode],
    layout: NodeLayout,
) -> Vec<[u32; 4]> {
    let mut out = node_words(std::slice::from_ref(root), NodeLayout::Aos);
    let words: Vec<_> = nodes.iter().map(CompressedNode::words).collect();
    match layout {
        NodeLayout::Aos => out.extend(words.iter().flatten()),
        NodeLayout::Soa => {
            for k in 0..crate::compressed::NODE_WORDS {
                out.extend(words.iter().map(|w| w[k]));
            }
        }
    }
    out
}

/// `vec4<u32>` words of an inline leaf entry.
pub const INLINE_WORDS: usize = 4;

/// An inline entry's first word holds the primitive's kind above this
/// bit (three bits), [`INLINE_ALPHA`] and its id below (ids under 2^28:
/// `scene_buffers::inline_entries` refuses more).
pub const INLINE_TAG_SHIFT: u32 = 29;

/// The bit of an inline entry's first word that marks a triangle with an
/// alpha (`reference::shapes::TRIANGLE_HAS_ALPHA`): only such entries read
/// the triangle record, for the coverage test.
pub const INLINE_ALPHA: u32 = 1 << 28;

/// The ids of `order` as the indexed layout holds them, four to a word.
pub fn indexed_entries(order: &[u32]) -> Vec<[u32; 4]> {
    order
        .chunks(4)
        .map(|c| std::array::from_fn(|k| c.get(k).copied().unwrap_or(0)))
        .collect()
}

/// Inline entries (`INLINE_WORDS` words each, side by side) regrouped as
/// [`LeafLayout::InlineSoa`] holds them: word `k` of entry `i` at
/// `k · n + i`.
pub fn soa_entries(inline: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let n = inline.len() / INLINE_WORDS;
    (0..INLINE_WORDS)
        .flat_map(|k| (0..n).map(move |i| inline[INLINE_WORDS * i + k]))
        .collect()
}

/// The records a walk reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WalkArrays {
    /// The binary, four-wide or brute-force records; for the compressed
    /// walk, the binary root's record alone (its exact box).
    pub nodes: Vec<BvhNode>,
    /// The compressed walk's nodes (empty for the others).
    pub compressed: Vec<CompressedNode>,
    /// The primitive order the leaves index.
    pub order: Vec<u32>,
}

/// The arrays a walk reads for `scene`, and whether they are the walk's:
/// `Err` with the reason where its records would need a deeper stack than
/// the kernels hold, or the compressed records cannot be made (the binary
/// tree's arrays come back with it, so a caller can go on with
/// [`Traversal::Binary`]).
pub fn arrays(scene: &Scene, traversal: Traversal) -> (WalkArrays, Result<(), String>) {
    let bvh = scene.bvh();
    let binary = || WalkArrays {
        nodes: bvh.nodes().to_vec(),
        compressed: Vec::new(),
        order: bvh.prim_order().to_vec(),
    };
    match traversal {
        Traversal::Binary => (binary(), Ok(())),
        Traversal::Wide => match wide_records(bvh.nodes()) {
            Ok(records) => (
                WalkArrays {
                    nodes: records,
                    ..binary()
                },
                Ok(()),
            ),
            Err(e) => (binary(), Err(e)),
        },
        Traversal::Compressed => {
            match crate::compressed::compress(bvh.nodes(), bvh.prim_order(), Rounding::Outward) {
                Ok(c) => (
                    WalkArrays {
                        nodes: bvh.nodes()[..1].to_vec(),
                        compressed: c.nodes,
                        order: c.order,
                    },
                    Ok(()),
                ),
                Err(e) => (binary(), Err(e)),
            }
        }
        Traversal::BruteForce => {
            let prims = scene.primitives().len() as u32;
            let root = bvh.nodes().first().copied().unwrap_or(BvhNode {
                min: [0.0; 3],
                index: 0,
                max: [0.0; 3],
                meta: BvhNode::LEAF,
            });
            let leaf = BvhNode {
                index: 0,
                meta: (prims << 2) | BvhNode::LEAF,
                ..root
            };
            (
                WalkArrays {
                    nodes: vec![leaf],
                    compressed: Vec::new(),
                    order: (0..prims).collect(),
                },
                Ok(()),
            )
        }
    }
}

/// Whether the walk over `nodes` ends whatever the rays: every interior
/// record's children come after it and lie inside the array, so each step
/// down goes to a later record and the walk visits finitely many (the
/// trusted kernels, [`crate::Checks::Trusted`], have no loop bounding to
/// stop a walk that cycles). The binary walk (brute force's one leaf
/// too): interior `i` has children `i + 1` and `index`, with
/// `i < index < len`. The four-wide walk: wide node `w`'s interior lanes
/// name wide nodes `c` with `w < c` whose records `1 + 4c ..= 4 + 4c`
/// exist. The compressed walk: `nodes` is the root's record alone, and
/// every interior child of a compressed node is a later node inside
/// `compressed` (`crate::compressed::check_order`). The error names the
/// first record out of order.
pub fn check_walk_order(
    nodes: &[BvhNode],
    compressed: &[CompressedNode],
    traversal: Traversal,
) -> Result<(), String> {
    let len = nodes.len();
    match traversal {
        Traversal::Compressed => {
            if len != 1 {
                return Err(format!(
                    "{len} records before the compressed nodes: the walk reads the root's alone"
                ));
            }
            crate::compressed::check_order(compressed)?;
        }
        Traversal::Binary | Traversal::BruteForce => {
            for (i, n) in nodes.iter().enumerate() {
                let child = n.index as usize;
                if n.meta & 3 != BvhNode::LEAF && (i + 1 >= len || child <= i || child >= len) {
                    return Err(format!(
                        "BVH node {i} of {len} has children {} and {child}: not after it, or past the end",
                        i + 1
                    ));
                }
            }
        }
        Traversal::Wide => {
            if len < 1 + WIDE_LANES || (len - 1) % WIDE_LANES != 0 {
                return Err(format!(
                    "{len} wide records: not the root and whole wide nodes"
                ));
            }
            for (r, n) in nodes.iter().enumerate().skip(1) {
                let w = (r - 1) / WIDE_LANES;
                let child = n.index as usize;
                let interior = n.meta != WIDE_EMPTY && n.meta & 3 != BvhNode::LEAF;
                if interior && (child <= w || 1 + WIDE_LANES * child + WIDE_LANES > len) {
                    return Err(format!(
                        "wide node {w}'s lane (record {r} of {len}) names wide node {child}: not after it, or past the end"
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The four-wide records of the binary tree `nodes` (module docs), or why
/// not: the walk defers up to all but one lane of each wide node it
/// enters, and the records are refused where some chain of wide nodes
/// could defer more than the kernels' [`BVH_STACK_SIZE`] at once.
pub fn wide_records(nodes: &[BvhNode]) -> Result<Vec<BvhNode>, String> {
    let empty = BvhNode {
        min: [0.0; 3],
        index: 0,
        max: [0.0; 3],
        meta: WIDE_EMPTY,
    };
    let Some(&root) = nodes.first() else {
        // No primitives: the root record and one wide node with no lanes.
        return Ok(vec![empty; 1 + WIDE_LANES]);
    };
    let mut out = vec![root];
    out.extend([empty; WIDE_LANES]);
    // (binary node, wide node made of its subtree's top)
    let mut pending = vec![(0usize, 0usize)];
    // Per wide node: its lanes, and its interior lanes' wide nodes (for
    // the stack need).
    let mut lanes_used: Vec<usize> = vec![0];
    let mut children: Vec<Vec<usize>> = vec![Vec::new()];
    while let Some((b, w)) = pending.pop() {
        let lanes = open(nodes, b);
        lanes_used[w] = lanes.len();
        for (lane, &n) in lanes.iter().enumerate() {
            let mut record = nodes[n];
            if !record.is_leaf() {
                let child = children.len();
                children.push(Vec::new());
                lanes_used.push(0);
                children[w].push(child);
                out.extend([empty; WIDE_LANES]);
                record.index = child as u32;
                pending.push((n, child));
            }
            out[1 + WIDE_LANES * w + lane] = record;
        }
    }
    if out.len() as u64 >= WIDE_LEAF_ENTRY as u64 {
        return Err(format!(
            "the four-wide walk's stack entries address fewer than {WIDE_LEAF_ENTRY} records; this tree needs {}",
            out.len()
        ));
    }
    // The walk enters the nearest lane it hits and stacks the others
    // (leaves too), so a wide node adds at most its lanes less one to
    // what its deepest interior lane needs. Children come after their
    // parent: one pass from the end sees every child's need first.
    let mut need = vec![0usize; children.len()];
    for w in (0..children.len()).rev() {
        let deepest = children[w].iter().map(|&c| need[c]).max().unwrap_or(0);
        need[w] = lanes_used[w].saturating_sub(1) + deepest;
    }
    if need[0] > BVH_STACK_SIZE {
        return Err(format!(
            "the four-wide walk of this tree could hold {} deferred lanes, more than its stack's {BVH_STACK_SIZE}",
            need[0]
        ));
    }
    Ok(out)
}

/// The binary nodes that become the lanes of binary node `b`'s wide node:
/// a leaf root is its own lane; else its children, then the interior lane
/// of largest surface area replaced by its two children (in place, so
/// lanes keep the tree's left-to-right order) until every lane is used or
/// every lane is a leaf.
fn open(nodes: &[BvhNode], b: usize) -> Vec<usize> {
    let n = &nodes[b];
    if n.is_leaf() {
        return vec![b];
    }
    let mut lanes = vec![b + 1, n.index as usize];
    while lanes.len() < WIDE_LANES {
        let widest = lanes
            .iter()
            .enumerate()
            .filter(|(_, &l)| !nodes[l].is_leaf())
            .max_by(|(_, &x), (_, &y)| {
                let (ax, ay) = (
                    nodes[x].bounds().surface_area(),
                    nodes[y].bounds().surface_area(),
                );
                ax.total_cmp(&ay)
            })
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let l = lanes[i];
        lanes.splice(i..=i, [l + 1, nodes[l].index as usize]);
    }
    lanes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(first: u32, count: u32, lo: f32) -> BvhNode {
        BvhNode {
            min: [lo; 3],
            index: first,
            max: [lo + 1.0; 3],
            meta: (count << 2) | BvhNode::LEAF,
        }
    }

    fn interior(right: u32, lo: f32, hi: f32) -> BvhNode {
        BvhNode {
            min: [lo; 3],
            index: right,
            max: [hi; 3],
            meta: 0,
        }
    }

    /// The leaf lanes of `records` (first entry, count), sorted.
    fn leaves(records: &[BvhNode]) -> Vec<(u32, u32)> {
        let mut out: Vec<_> = records[1..]
            .iter()
            .filter(|r| r.meta != WIDE_EMPTY && r.is_leaf())
            .map(|r| (r.index, r.count()))
            .collect();
        out.sort();
        out
    }

    #[test]
    fn real_trees_walk_in_order_and_cycles_are_refused() {
        // Every built-in scene's records, each walk: in order.
        for name in reference::builtin::NAMES {
            let scene = reference::load_scene(name).unwrap();
            for t in Traversal::ALL {
                let (walk, refused) = arrays(&scene, t);
                if t == Traversal::Compressed {
                    refused.unwrap_or_else(|e| panic!("{name}: {e}"));
                }
                check_walk_order(&walk.nodes, &walk.compressed, t)
                    .unwrap_or_else(|e| panic!("{name} {t:?}: {e}"));
            }
        }
        // A right child pointing back at its parent: a walk that cycles.
        let tree = [interior(2, 0.0, 2.0), leaf(0, 1, 0.0), leaf(1, 1, 1.0)];
        check_walk_order(&tree, &[], Traversal::Binary).unwrap();
        let mut cyclic = tree;
        cyclic[0].index = 0;
        assert!(check_walk_order(&cyclic, &[], Traversal::Binary).is_err());
        let mut past = tree;
        past[0].index = 3;
        assert!(check_walk_order(&past, &[], Traversal::Binary).is_err());
        // An interior last record: its left child would be past the end.
        assert!(check_walk_order(&[interior(1, 0.0, 1.0)], &[], Traversal::Binary).is_err());
        // Wide: an interior lane naming its own wide node, or one past the end.
        let scene = reference::load_scene("rtow-final").unwrap();
        let wide = wide_records(scene.bvh().nodes()).unwrap();
        let lane = (1..wide.len())
            .find(|&r| wide[r].meta != WIDE_EMPTY && !wide[r].is_leaf())
            .expect("rtow-final has interior lanes");
        let mut own = wide.clone();
        own[lane].index = ((lane - 1) / WIDE_LANES) as u32;
        assert!(check_walk_order(&own, &[], Traversal::Wide).is_err());
        let mut beyond = wide;
        beyond[lane].index = u32::MAX >> 1;
        assert!(check_walk_order(&beyond, &[], Traversal::Wide).is_err());
        // Compressed: a node naming itself, one before it, or nodes past
        // the end; no nodes; records other than the root's before them.
        let (walk, refused) = arrays(&scene, Traversal::Compressed);
        refused.unwrap();
        let root = &walk.nodes;
        let c = &walk.compressed;
        check_walk_order(root, c, Traversal::Compressed).unwrap();
        let w = (1..c.len())
            .find(|&w| c[w].imask != 0)
            .expect("rtow-final has compressed nodes below the root with interior children");
        for (what, base) in [
            ("itself", w as u32),
            ("a node before it", w as u32 - 1),
            (
                "nodes past the end",
                (c.len() - c[w].imask.count_ones() as usize + 1) as u32,
            ),
        ] {
            let mut bad = c.clone();
            bad[w].child_base = base;
            let e = check_walk_order(root, &bad, Traversal::Compressed).expect_err(what);
            assert!(
                e.contains(&format!("compressed node {w} of")),
                "{what}: {e}"
            );
        }
        // The last valid base: its children end at the last node.
        let mut last = c.clone();
        last[w].child_base = (c.len() - c[w].imask.count_ones() as usize) as u32;
        check_walk_order(root, &last, Traversal::Compressed).unwrap();
        assert!(check_walk_order(root, &[], Traversal::Compressed).is_err());
        assert!(check_walk_order(&[root[0], root[0]], c, Traversal::Compressed).is_err());
    }

    #[test]
    fn a_leaf_root_is_one_lane() {
        let r = wide_records(&[leaf(0, 3, 0.0)]).unwrap();
        assert_eq!(r.len(), 1 + WIDE_LANES);
        assert_eq!(r[1], leaf(0, 3, 0.0));
        assert!(r[2..].iter().all(|l| l.meta == WIDE_EMPTY));
    }

    #[test]
    fn every_leaf_appears_once_with_its_box() {
        // A scene's real tree: every binary leaf is a lane, bit for bit.
        let scene = reference::load_scene("rtow-final").unwrap();
        let nodes = scene.bvh().nodes();
        let r = wide_records(nodes).unwrap();
        let mut binary: Vec<_> = nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| (n.index, n.count()))
            .collect();
        binary.sort();
        assert_eq!(leaves(&r), binary);
        for lane in &r[1..] {
            if lane.meta != WIDE_EMPTY && lane.is_leaf() {
                assert!(nodes.contains(lane), "{lane:?} is not a binary leaf");
            }
        }
        // Interior lanes: a binary interior node's box and axis, and the
        // wide node they name exists.
        let wide = (r.len() - 1) / WIDE_LANES;
        for lane in r[1..]
            .iter()
            .filter(|l| l.meta != WIDE_EMPTY && !l.is_leaf())
        {
            assert!((lane.index as usize) < wide);
            assert!(nodes.iter().any(|n| !n.is_leaf()
                && n.min == lane.min
                && n.max == lane.max
                && n.meta == lane.meta));
        }
        // Most lanes are used (the point of opening the widest lanes).
        let used = r[1..].iter().filter(|l| l.meta != WIDE_EMPTY).count();
        assert!(
            used * 10 >= (r.len() - 1) * 7,
            "{used} of {} lanes used",
            r.len() - 1
        );
    }

    #[test]
    fn the_widest_interior_lane_is_opened() {
        // root(0) -> a(1), b(4); a -> leaves 2, 3; b -> c(5), leaf 8;
        // c -> leaves 6, 7. b is wider than a: opened first, into c and
        // leaf 8; then c (area 96) is wider than a (24): opened into its
        // leaves. Four lanes, in the tree's order: a, 6, 7, 8.
        let nodes = [
            interior(4, 0.0, 2.0),
            interior(3, 0.0, 2.0),
            leaf(0, 1, 0.0),
            leaf(1, 1, 1.0),
            interior(8, 2.0, 10.0),
            interior(7, 2.0, 6.0),
            leaf(2, 1, 2.0),
            leaf(3, 1, 3.0),
            leaf(4, 1, 7.0),
        ];
        assert_eq!(open(&nodes, 0), vec![1, 6, 7, 8]);
        let r = wide_records(&nodes).unwrap();
        assert_eq!(r.len(), 1 + 2 * WIDE_LANES);
        assert_eq!(r[1].index, 1, "a's lane names wide node 1");
        assert_eq!(&r[2..5], &[nodes[6], nodes[7], nodes[8]]);
        assert_eq!(&r[5..7], &[nodes[2], nodes[3]]);
        assert!(r[7..].iter().all(|l| l.meta == WIDE_EMPTY));
    }

    /// A spine of `len` interior nodes, each with a small two-leaf node on
    /// the left and the rest of the spine (wider) on the right: every wide
    /// node opens the spine twice and holds four interior lanes, three of
    /// them deferred by the walk.
    fn spine(len: u32) -> Vec<BvhNode> {
        let mut nodes = Vec::new();
        for k in 0..len {
            let at = nodes.len() as u32;
            nodes.push(interior(at + 4, 0.0, 1000.0 - k as f32));
            nodes.push(interior(at + 3, k as f32, k as f32 + 1.0));
            nodes.push(leaf(2 * k, 1, k as f32));
            nodes.push(leaf(2 * k + 1, 1, k as f32));
        }
        nodes.push(leaf(2 * len, 1, 0.0));
        nodes
    }

    #[test]
    fn a_walk_that_could_outgrow_the_stack_is_refused() {
        // 30 spine nodes: 10 wide nodes deep, 3 deferred each.
        assert!(wide_records(&spine(30)).is_ok());
        // 90: 30 deep, 90 deferred > 64.
        let e = wide_records(&spine(90)).unwrap_err();
        assert!(e.contains("more than its stack's 64"), "{e}");
        // A caterpillar (a leaf on the left of each spine node): three
        // leaves and the spine's rest a wide node, three deferred each (the
        // leaves wait on the stack too): 60 spine nodes are 20 wide nodes
        // deep (60 deferred, accepted), 75 are 25 (75, refused).
        let caterpillar = |len: u32| {
            let mut nodes = Vec::new();
            for i in 0..len {
                let at = nodes.len() as u32;
                nodes.push(interior(at + 2, 0.0, 1000.0 - i as f32));
                nodes.push(leaf(i, 1, 0.0));
            }
            nodes.push(leaf(len, 1, 0.0));
            nodes
        };
        assert!(wide_records(&caterpillar(60)).is_ok());
        assert!(wide_records(&caterpillar(75)).is_err());
    }
}
