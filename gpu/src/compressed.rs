//! The compressed eight-wide BVH that the `cwbvh8` walk reads
//! (`Traversal::Compressed`): the binary tree collapsed to nodes of up to
//! eight children whose boxes are quantized to 8 bits per bound relative
//! to the node, in the manner of Ylitie, Karras and Laine, "Efficient
//! Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs" (HPG
//! 2017). A node is 80 bytes ([`CompressedNode`]): the binary tree's
//! boxes for its eight lanes would be 256.
//!
//! The collapse is the paper's surface-area one (§3.1), by dynamic
//! programming over the binary tree: each binary interior node either
//! becomes a wide node or gives its two children's lanes to its parent's,
//! whichever costs less as Σ A(wide node)·C_node + Σ A(leaf)·entries·C_prim.
//! A leaf child is a binary leaf as built: its entries, under a box that
//! contains the binary leaf's box.
//!
//! Why the hits stay the binary walk's bit for bit: a child's dequantized
//! box, computed in f32 exactly as the kernel computes it
//! ([`dequantize`]), contains the child's exact box, bound by bound
//! ([`quantize`] steps a bound outward until it does). The box test is
//! monotone in the bounds (`reference::bvh::intersect_aabb_padded`), so a
//! box that contains another passes wherever the inner one does, and
//! every primitive the admits rule (`Bvh::admits`) lets hit is offered to
//! the same leaf test as in the binary walk, ties in t to the smaller id.
//! A looser box only adds visits. The root's exact box is kept (the
//! walk's first test and the box every ray's pad is taken from).
//!
//! Exactness of the dequantization: the scale is 2^e with e in
//! [[`EXPONENT_MIN`], [`EXPONENT_MAX`]], so `q · 2^e` (q ≤ 255) is an
//! exact normal f32 (or 0) that never overflows; `p + q · 2^e` is one
//! correctly rounded addition (Vulkan's f32 addition is correctly
//! rounded; a fused multiply-add gives the same bits because the product
//! is exact). The origin `p` is never subnormal, so a GPU that flushes
//! subnormal inputs to zero (the H100) reads the `p` the host verified;
//! flushing a subnormal result is monotone, as is the flush of the
//! primitive bounds it is compared with.

use reference::bvh::{BvhNode, BVH_STACK_SIZE};

/// Children of a compressed node.
pub const WIDTH: usize = 8;

/// `vec4<u32>` words of a compressed node ([`CompressedNode::words`]).
pub const NODE_WORDS: usize = 5;

/// `vec4<u32>` words before the first node in the `nodes` binding: the
/// binary root's record (its exact box and its `meta`).
pub const HEADER_WORDS: usize = 2;

/// The bit from which the walk's group word holds its hit interior
/// children (one bit a slot, below it the node's interior mask).
pub const HIT_SHIFT: u32 = 24;

/// A leaf child's `meta` byte: its entry count above this bit, its first
/// entry's offset from the node's `leaf_base` below.
pub const LEAF_COUNT_SHIFT: u32 = 5;

/// The most entries one leaf child holds (three bits of count).
pub const LEAF_MAX_COUNT: u32 = (1 << (8 - LEAF_COUNT_SHIFT)) - 1;

/// The largest offset of a leaf child's first entry (five bits).
pub const LEAF_MAX_OFFSET: u32 = (1 << LEAF_COUNT_SHIFT) - 1;

/// The least scale exponent: 2^-126 is the least normal f32, so `q · 2^e`
/// never underflows.
pub const EXPONENT_MIN: i32 = -126;

/// The greatest scale exponent: 255 · 2^119 < 2^127, so `q · 2^e` never
/// overflows (a fused `p + q · 2^e` then rounds as the separate one).
pub const EXPONENT_MAX: i32 = 119;

/// How the box bounds are rounded to the 8-bit grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounding {
    /// Down for a minimum, up for a maximum, then stepped outward until
    /// the dequantized box contains the exact one: what every walk reads.
    Outward,
    /// The mutation tests' defect: a minimum rounded up and a maximum
    /// down (floor and ceil swapped), nothing stepped. Such boxes lose
    /// hits, and the equality gates must say so.
    Inward,
}

/// One node of the compressed tree: 80 bytes, five `vec4<u32>` words
/// ([`Self::words`]). Child slot `s` is empty, an interior child (bit `s`
/// of `imask`: wide node `child_base` + the interior children in the
/// slots before it) or a leaf (`meta[s]` nonzero: `meta[s] >>
/// LEAF_COUNT_SHIFT` entries from `leaf_base + (meta[s] & LEAF_MAX_OFFSET)`).
/// Its box on axis k is `p[k] + q · 2^exponent[k]` for q = `lo[k][s]` and
/// `hi[k][s]` ([`dequantize`]). The slots are assigned so that a ray's
/// nearest children come first when the walk takes the slots in the
/// order of its direction's octant ([`assign_slots`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompressedNode {
    /// `p`: the grid's origin, at or below every child's minimum.
    pub origin: [f32; 3],
    /// `e` of each axis: the grid's step is 2^e.
    pub exponent: [i8; 3],
    /// Which slots hold interior children.
    pub imask: u8,
    /// The first interior child's wide node; the others follow it in
    /// slot order.
    pub child_base: u32,
    /// The first leaf entry (in the walk's primitive order) of the leaf
    /// children, which follow each other in slot order.
    pub leaf_base: u32,
    /// Per slot: 0 for an empty or interior slot; a leaf's count and
    /// offset.
    pub meta: [u8; WIDTH],
    /// Quantized minima, per axis and slot.
    pub lo: [[u8; WIDTH]; 3],
    /// Quantized maxima, per axis and slot.
    pub hi: [[u8; WIDTH]; 3],
}

/// `2^e`, built from its bits as the kernel builds it.
pub fn scale(e: i8) -> f32 {
    f32::from_bits(((e as i32 + 127) as u32) << 23)
}

/// A quantized bound in f32, operation for operation as the kernel
/// computes it: `p + f32(q) · 2^e`.
pub fn dequantize(p: f32, e: i8, q: u8) -> f32 {
    p + q as f32 * scale(e)
}

fn pack(bytes: &[u8]) -> u32 {
    u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])
}

fn unpack(lo: u32, hi: u32) -> [u8; WIDTH] {
    let (a, b) = (lo.to_le_bytes(), hi.to_le_bytes());
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
}

impl CompressedNode {
    /// The node's five words: `p` and the exponents and `imask` (one byte
    /// each, x lowest); `child_base`, `leaf_base`, `meta`; then the
    /// quantized bounds, two words (slots 0–3, 4–7; slot `s` in byte
    /// `s & 3`) per axis and side: minimum x, y, z, maximum x, y, z.
    pub fn words(&self) -> [[u32; 4]; NODE_WORDS] {
        let e = self.exponent.map(|e| e as u8);
        let two = |b: &[u8; WIDTH]| [pack(&b[..4]), pack(&b[4..])];
        let q: Vec<u32> = (self.lo.iter().chain(&self.hi)).flat_map(two).collect();
        [
            [
                self.origin[0].to_bits(),
                self.origin[1].to_bits(),
                self.origin[2].to_bits(),
                pack(&[e[0], e[1], e[2], self.imask]),
            ],
            [
                self.child_base,
                self.leaf_base,
                pack(&self.meta[..4]),
                pack(&self.meta[4..]),
            ],
            [q[0], q[1], q[2], q[3]],
            [q[4], q[5], q[6], q[7]],
            [q[8], q[9], q[10], q[11]],
        ]
    }

    /// The node [`Self::words`] came from.
    pub fn from_words(w: &[[u32; 4]; NODE_WORDS]) -> Self {
        let q: Vec<u32> = w[2..].iter().flatten().copied().collect();
        let b = w[0][3].to_le_bytes();
        let side = |k: usize| unpack(q[2 * k], q[2 * k + 1]);
        CompressedNode {
            origin: [0, 1, 2].map(|k| f32::from_bits(w[0][k])),
            exponent: [b[0] as i8, b[1] as i8, b[2] as i8],
            imask: b[3],
            child_base: w[1][0],
            leaf_base: w[1][1],
            meta: unpack(w[1][2], w[1][3]),
            lo: [side(0), side(1), side(2)],
            hi: [side(3), side(4), side(5)],
        }
    }

    /// Whether slot `s` holds a child.
    pub fn is_live(&self, s: usize) -> bool {
        self.imask & (1 << s) != 0 || self.meta[s] != 0
    }

    /// The wide node of slot `s`, if it is an interior child.
    pub fn child(&self, s: usize) -> Option<u32> {
        (self.imask & (1 << s) != 0).then(|| {
            let before = self.imask & ((1u16 << s) - 1) as u8;
            self.child_base + before.count_ones()
        })
    }

    /// The entries of slot `s` (first, count), if it is a leaf.
    pub fn leaf(&self, s: usize) -> Option<(u32, u32)> {
        let m = self.meta[s] as u32;
        (self.imask & (1 << s) == 0 && m != 0).then(|| {
            (
                self.leaf_base + (m & LEAF_MAX_OFFSET),
                m >> LEAF_COUNT_SHIFT,
            )
        })
    }

    /// Slot `s`'s box as the kernel dequantizes it: (minimum, maximum).
    pub fn child_box(&self, s: usize) -> ([f32; 3], [f32; 3]) {
        let at = |q: &[[u8; WIDTH]; 3]| {
            [0, 1, 2].map(|k| dequantize(self.origin[k], self.exponent[k], q[k][s]))
        };
        (at(&self.lo), at(&self.hi))
    }
}

/// The compressed tree of a binary tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Compressed {
    /// Node 0 is the root; a node's interior children come after it.
    pub nodes: Vec<CompressedNode>,
    /// The primitive order the leaf children index: the binary leaves'
    /// entries regrouped so that each node's leaf children are one run.
    pub order: Vec<u32>,
    /// Per node and slot, the binary node the child was made from
    /// (`u32::MAX` for an empty slot): what its box must contain.
    pub sources: Vec<[u32; WIDTH]>,
}

/// Relative costs of visiting a wide node and of one primitive test, for
/// the collapse (the paper's, and the reference's 8-wide collapse's: equal,
/// `reference::bvh`'s collapse measured them so on the CPU).
const NODE_COST: f64 = 1.0;
const PRIM_COST: f64 = 1.0;

/// The collapse: for each binary node n and lane budget j (1..=8), how
/// its subtree fills at most j lanes of its parent's wide node.
struct Plan {
    /// `split[n][j - 1]`: 0 where the subtree takes one lane (a leaf, or
    /// a wide node of its own); else the lanes its left child gets, the
    /// right child getting the rest.
    split: Vec<[u8; WIDTH]>,
    /// For an interior node made a wide node: the lanes of its eight its
    /// left child gets.
    own: Vec<u8>,
}

impl Plan {
    fn new(nodes: &[BvhNode]) -> Self {
        let mut plan = Plan {
            split: vec![[0; WIDTH]; nodes.len()],
            own: vec![0; nodes.len()],
        };
        if !nodes.is_empty() {
            plan.cost(nodes, 0);
        }
        plan
    }

    /// The least cost of subtree `n` in at most j lanes, for each j
    /// (post-order: only the costs of one root-to-node path are alive).
    fn cost(&mut self, nodes: &[BvhNode], n: usize) -> [f64; WIDTH] {
        let node = &nodes[n];
        let area = node.bounds().surface_area() as f64;
        if node.is_leaf() {
            return [area * node.count() as f64 * PRIM_COST; WIDTH];
        }
        let left = self.cost(nodes, n + 1);
        let right = self.cost(nodes, node.index as usize);
        // Both children in at most j lanes, the left one given k (the
        // least k on ties, so the plan does not depend on float noise
        // across machines more than the costs do).
        let both = |j: usize| {
            let mut best = (f64::INFINITY, 0);
            for k in 1..j {
                let c = left[k - 1] + right[j - k - 1];
                if c < best.0 {
                    best = (c, k);
                }
            }
            best
        };
        let (children, k) = both(WIDTH);
        let as_node = area * NODE_COST + children;
        self.own[n] = k as u8;
        let mut out = [as_node; WIDTH];
        for j in 2..=WIDTH {
            let (c, k) = both(j);
            if c < as_node {
                out[j - 1] = c;
                self.split[n][j - 1] = k as u8;
            }
        }
        out
    }

    /// The binary nodes subtree `n` puts in the lanes of its parent's
    /// node when given at most `j`, in the tree's order.
    fn lanes(&self, nodes: &[BvhNode], n: usize, j: usize, out: &mut Vec<usize>) {
        match self.split[n][j - 1] as usize {
            0 => out.push(n),
            k => {
                self.lanes(nodes, n + 1, k, out);
                self.lanes(nodes, nodes[n].index as usize, j - k, out);
            }
        }
    }

    /// The children of binary node `b`'s wide node.
    fn children(&self, nodes: &[BvhNode], b: usize) -> Vec<usize> {
        if nodes[b].is_leaf() {
            return vec![b];
        }
        let k = self.own[b] as usize;
        let mut out = Vec::with_capacity(WIDTH);
        self.lanes(nodes, b + 1, k, &mut out);
        self.lanes(nodes, nodes[b].index as usize, WIDTH - k, &mut out);
        out
    }
}

/// Which slot each child gets: the slot whose corner direction (bit k
/// set: −1 along axis k, else +1) best matches the child's centre seen
/// from the parent's, greedily over all pairs, best first. A ray of
/// direction octant `o` (bit k: negative along k) takes the slots in the
/// order `s ^ o` from 7 down, so slot `!o & 7`, the corner the ray comes
/// from, first.
fn assign_slots(parent: &BvhNode, children: &[&BvhNode]) -> [Option<usize>; WIDTH] {
    let centre = |n: &BvhNode| [0, 1, 2].map(|k| 0.5 * (n.min[k] as f64 + n.max[k] as f64));
    let pc = centre(parent);
    let mut pairs = Vec::with_capacity(children.len() * WIDTH);
    for (i, c) in children.iter().enumerate() {
        let cc = centre(c);
        for s in 0..WIDTH {
            let score: f64 = (0..3)
                .map(|k| {
                    let d = cc[k] - pc[k];
                    if (s >> k) & 1 == 1 {
                        -d
                    } else {
                        d
                    }
                })
                .sum();
            pairs.push((score, i, s));
        }
    }
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    let mut slots = [None; WIDTH];
    let mut placed = vec![false; children.len()];
    for (_, i, s) in pairs {
        if !placed[i] && slots[s].is_none() {
            slots[s] = Some(i);
            placed[i] = true;
        }
    }
    slots
}

/// The grid of one axis for the bounds `(lo, hi)` of a node's children:
/// the origin, the exponent and each child's (lo, hi) byte.
type Axis = (f32, i8, Vec<(u8, u8)>);

/// Quantizes one axis of a node's children, or says why it cannot.
pub fn quantize(bounds: &[(f32, f32)], rounding: Rounding) -> Result<Axis, String> {
    let lo_min = bounds.iter().map(|b| b.0).fold(f32::INFINITY, f32::min);
    let hi_max = bounds.iter().map(|b| b.1).fold(f32::NEG_INFINITY, f32::max);
    let nan = bounds.iter().any(|b| b.0.is_nan() || b.1.is_nan());
    if nan || !lo_min.is_finite() || !hi_max.is_finite() {
        return Err(format!(
            "a child box's bounds {lo_min}..{hi_max} are not finite"
        ));
    }
    // Never subnormal (module docs): a subnormal minimum's origin is the
    // least normal number below it, or 0.
    let p = if lo_min != 0.0 && lo_min.abs() < f32::MIN_POSITIVE {
        if lo_min < 0.0 {
            -f32::MIN_POSITIVE
        } else {
            0.0
        }
    } else {
        lo_min
    };
    let extent = hi_max as f64 - p as f64;
    let mut e = if extent > 0.0 {
        ((extent / 255.0).log2().ceil() as i32).clamp(EXPONENT_MIN, EXPONENT_MAX)
    } else {
        EXPONENT_MIN
    };
    loop {
        if let Some(q) = quantize_at(bounds, p, e as i8, rounding) {
            return Ok((p, e as i8, q));
        }
        e += 1;
        if e > EXPONENT_MAX {
            return Err(format!(
                "child boxes {lo_min}..{hi_max} span more than 255 · 2^{EXPONENT_MAX}"
            ));
        }
    }
}

/// Each bound on the grid of origin `p` and step 2^e, or `None` where a
/// maximum does not fit in 255 steps.
fn quantize_at(bounds: &[(f32, f32)], p: f32, e: i8, rounding: Rounding) -> Option<Vec<(u8, u8)>> {
    let step = scale(e) as f64;
    let at = |q: u32| dequantize(p, e, q as u8);
    let grid = |x: f32| (x as f64 - p as f64) / step;
    let mut out = Vec::with_capacity(bounds.len());
    for &(lo, hi) in bounds {
        let (mut ql, mut qh) = match rounding {
            Rounding::Outward => (grid(lo).floor(), grid(hi).ceil()),
            Rounding::Inward => (grid(lo).ceil(), grid(hi).floor()),
        };
        if qh > 255.0 {
            return None;
        }
        ql = ql.clamp(0.0, 255.0);
        qh = qh.clamp(0.0, 255.0);
        let (mut ql, mut qh) = (ql as u32, qh as u32);
        if rounding == Rounding::Outward {
            // The estimate came from f64; the f32 the kernel computes
            // decides. At q = 0 the bound is `p`, at or below `lo`. A step
            // inward is taken only where it tightens the f32 bound.
            while ql > 0 && at(ql) > lo {
                ql -= 1;
            }
            while ql < 255 && at(ql + 1) <= lo && at(ql + 1) > at(ql) {
                ql += 1;
            }
            while at(qh) < hi {
                if qh == 255 {
                    return None;
                }
                qh += 1;
            }
            while qh > ql && at(qh - 1) >= hi && at(qh - 1) < at(qh) {
                qh -= 1;
            }
        }
        out.push((ql as u8, qh as u8));
    }
    Some(out)
}

/// The compressed tree of the binary tree `nodes` (with its primitive
/// order), or why not: a binary leaf of more than [`LEAF_MAX_COUNT`]
/// entries, a node's leaf entries past [`LEAF_MAX_OFFSET`], a box that
/// cannot be quantized, or a tree whose walk could hold more deferred
/// groups than the kernels' [`BVH_STACK_SIZE`] (the walk stacks at most
/// one group of a node's remaining interior children a level).
pub fn compress(
    nodes: &[BvhNode],
    prim_order: &[u32],
    rounding: Rounding,
) -> Result<Compressed, String> {
    if nodes.is_empty() {
        return Err("the compressed walk needs a tree of at least one node".into());
    }
    let plan = Plan::new(nodes);
    let mut out = Compressed::default();
    out.nodes.push(CompressedNode::default());
    out.sources.push([u32::MAX; WIDTH]);
    // (binary node, its wide node)
    let mut pending = vec![(0usize, 0usize)];
    while let Some((b, w)) = pending.pop() {
        let kids = plan.children(nodes, b);
        let records: Vec<&BvhNode> = kids.iter().map(|&c| &nodes[c]).collect();
        let slots = assign_slots(&nodes[b], &records);
        let mut node = CompressedNode {
            child_base: out.nodes.len() as u32,
            leaf_base: out.order.len() as u32,
            ..CompressedNode::default()
        };
        let mut offset = 0u32;
        let mut live = Vec::with_capacity(WIDTH);
        for (s, slot) in slots.iter().enumerate() {
            let Some(i) = *slot else { continue };
            let (c, child) = (kids[i], records[i]);
            out.sources[w][s] = c as u32;
            live.push((s, child));
            if child.is_leaf() {
                let count = child.count();
                if count == 0 || count > LEAF_MAX_COUNT || offset > LEAF_MAX_OFFSET {
                    return Err(format!(
                        "binary leaf {c} of {count} entries at offset {offset}: the compressed walk's leaves hold 1 to {LEAF_MAX_COUNT} entries at offsets up to {LEAF_MAX_OFFSET}"
                    ));
                }
                node.meta[s] = ((count << LEAF_COUNT_SHIFT) | offset) as u8;
                let first = child.index as usize;
                out.order
                    .extend_from_slice(&prim_order[first..first + count as usize]);
                offset += count;
            } else {
                node.imask |= 1 << s;
                pending.push((c, out.nodes.len()));
                out.nodes.push(CompressedNode::default());
                out.sources.push([u32::MAX; WIDTH]);
            }
        }
        for k in 0..3 {
            let bounds: Vec<(f32, f32)> = live.iter().map(|(_, n)| (n.min[k], n.max[k])).collect();
            let (p, e, q) =
                quantize(&bounds, rounding).map_err(|why| format!("binary node {b}: {why}"))?;
            node.origin[k] = p;
            node.exponent[k] = e;
            for (&(s, _), (ql, qh)) in live.iter().zip(q) {
                node.lo[k][s] = ql;
                node.hi[k][s] = qh;
            }
        }
        out.nodes[w] = node;
    }
    if out.nodes.len() as u64 > u32::MAX as u64 || out.order.len() as u64 > u32::MAX as u64 {
        return Err("the compressed tree needs more than 2^32 records".into());
    }
    let need = stack_need(&out.nodes);
    if need > BVH_STACK_SIZE {
        return Err(format!(
            "the compressed walk of this tree could hold {need} deferred groups, more than its stack's {BVH_STACK_SIZE}"
        ));
    }
    Ok(out)
}

/// The most groups the walk can hold on its stack: a node with two or
/// more interior children may leave one group (the children it has not
/// entered) below the groups of the child it enters. Children come after
/// their parent, so one pass from the end sees every child first.
pub fn stack_need(nodes: &[CompressedNode]) -> usize {
    let mut need = vec![0usize; nodes.len()];
    for w in (0..nodes.len()).rev() {
        let n = &nodes[w];
        let below = (0..WIDTH)
            .filter_map(|s| n.child(s))
            .map(|c| need.get(c as usize).copied().unwrap_or(0))
            .max()
            .unwrap_or(0);
        need[w] = usize::from(n.imask.count_ones() >= 2) + below;
    }
    need.first().copied().unwrap_or(0)
}

/// Whether the walk over `nodes` ends: every interior child is a later
/// node inside the array (so each step down goes to a later node, and a
/// walk visits each node at most once), and node 0, where the walk
/// starts, exists. The error names the first node out of order. (Leaf
/// entries are read with bounds checks, as the other walks' are.)
pub fn check_order(nodes: &[CompressedNode]) -> Result<(), String> {
    let len = nodes.len();
    if len == 0 {
        return Err("no compressed nodes: the walk starts at node 0".into());
    }
    for (w, n) in nodes.iter().enumerate() {
        let end = n.child_base as u64 + n.imask.count_ones() as u64;
        if n.imask != 0 && (n.child_base as usize <= w || end > len as u64) {
            return Err(format!(
                "compressed node {w} of {len} names nodes {}..{end}: not after it, or past the end",
                n.child_base
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use reference::bvh::Bvh;
    use reference::geometry::Aabb;

    /// Every live slot's dequantized box contains its binary node's box,
    /// bound by bound in f32; every binary leaf is one leaf child with
    /// its entries; every interior child names the node made from its
    /// binary node. The error names the first slot that is not so.
    fn check(nodes: &[BvhNode], prim_order: &[u32], c: &Compressed) -> Result<(), String> {
        let mut made = vec![u32::MAX; nodes.len()];
        made[0] = 0;
        let mut entries = 0usize;
        for (w, n) in c.nodes.iter().enumerate() {
            for s in 0..WIDTH {
                let src = c.sources[w][s];
                if !n.is_live(s) {
                    if src != u32::MAX {
                        return Err(format!("node {w} slot {s}: empty, made from {src}"));
                    }
                    continue;
                }
                let b = &nodes[src as usize];
                let (lo, hi) = n.child_box(s);
                for k in 0..3 {
                    if !(lo[k] <= b.min[k] && hi[k] >= b.max[k]) {
                        return Err(format!(
                            "node {w} slot {s} axis {k}: {}..{} does not contain {}..{} (p {}, e {}, q {}..{})",
                            lo[k], hi[k], b.min[k], b.max[k], n.origin[k], n.exponent[k], n.lo[k][s], n.hi[k][s]
                        ));
                    }
                }
                match (n.child(s), n.leaf(s)) {
                    (Some(child), None) if !b.is_leaf() => made[src as usize] = child,
                    (None, Some((first, count))) if b.is_leaf() => {
                        let (f, m) = (first as usize, count as usize);
                        let (bf, bm) = (b.index as usize, b.count() as usize);
                        if c.order[f..f + m] != prim_order[bf..bf + bm] {
                            return Err(format!(
                                "node {w} slot {s}: entries not binary leaf {src}'s"
                            ));
                        }
                        entries += m;
                    }
                    _ => {
                        return Err(format!(
                            "node {w} slot {s}: kind unlike binary node {src}'s"
                        ))
                    }
                }
            }
        }
        // Each interior child's node was made from that binary node.
        for (w, n) in c.nodes.iter().enumerate() {
            for s in 0..WIDTH {
                if let Some(child) = n.child(s) {
                    let src = c.sources[w][s] as usize;
                    if made[src] != child {
                        return Err(format!("node {w} slot {s}: names node {child}"));
                    }
                }
            }
        }
        let leaf_entries: usize = nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.count() as usize)
            .sum();
        if entries != leaf_entries || c.order.len() != leaf_entries {
            return Err(format!(
                "{entries} leaf entries in the children, {} in the order, {leaf_entries} in the binary leaves",
                c.order.len()
            ));
        }
        Ok(())
    }

    fn tree(bounds: &[Aabb]) -> Bvh {
        Bvh::build(bounds).0
    }

    /// A float of any sign and of magnitude from subnormal to 2^60, or 0.
    fn coordinate() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(0.0f32),
            (any::<bool>(), 1u32..(1 << 23), -149i32..-120).prop_map(|(neg, m, e)| {
                let v = (m as f64 * 2f64.powi(e - 23)) as f32;
                if neg {
                    -v
                } else {
                    v
                }
            }),
            (any::<bool>(), 0.5f32..1.0, -30i32..61).prop_map(|(neg, m, e)| {
                let v = m * 2f32.powi(e);
                if neg {
                    -v
                } else {
                    v
                }
            }),
        ]
    }

    /// A box around a coordinate, of extent 0, a few ulps, or any size.
    fn a_box() -> impl Strategy<Value = Aabb> {
        (
            [coordinate(), coordinate(), coordinate()],
            [0u32..4, 0u32..4, 0u32..4],
            [coordinate(), coordinate(), coordinate()],
        )
            .prop_map(|(c, kind, size)| {
                let mut min = [0.0f32; 3];
                let mut max = [0.0f32; 3];
                for k in 0..3 {
                    let (lo, hi) = match kind[k] {
                        0 => (c[k], c[k]),
                        1 => (c[k], f32::from_bits(c[k].to_bits() + 3).max(c[k])),
                        _ => (c[k].min(c[k] + size[k]), c[k].max(c[k] + size[k])),
                    };
                    min[k] = lo;
                    max[k] = if hi.is_finite() && hi >= lo { hi } else { lo };
                }
                Aabb {
                    min: glam::Vec3::from(min),
                    max: glam::Vec3::from(max),
                }
            })
    }

    proptest! {
        // 256 trees of up to 300 boxes from subnormal to 2^60, of every
        // extent: a few seconds in a debug build.
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        #[test]
        fn every_dequantized_box_contains_its_exact_box(bounds in prop::collection::vec(a_box(), 1..300)) {
            let bvh = tree(&bounds);
            let c = compress(bvh.nodes(), bvh.prim_order(), Rounding::Outward).map_err(TestCaseError::fail)?;
            check(bvh.nodes(), bvh.prim_order(), &c).map_err(TestCaseError::fail)?;
            check_order(&c.nodes).map_err(TestCaseError::fail)?;
            for n in &c.nodes {
                prop_assert_eq!(CompressedNode::from_words(&n.words()), *n);
                for k in 0..3 {
                    let e = n.exponent[k] as i32;
                    prop_assert!((EXPONENT_MIN..=EXPONENT_MAX).contains(&e));
                    prop_assert!(n.origin[k] == 0.0 || n.origin[k].is_normal(), "origin {}", n.origin[k]);
                }
            }
        }
    }

    #[test]
    fn real_trees_are_contained_and_inward_rounding_is_not() {
        for name in ["rtow-final", "cornell"] {
            let scene = reference::load_scene(name).unwrap();
            let bvh = scene.bvh();
            let c = compress(bvh.nodes(), bvh.prim_order(), Rounding::Outward).unwrap();
            check(bvh.nodes(), bvh.prim_order(), &c).unwrap_or_else(|e| panic!("{name}: {e}"));
            // The mutants' rounding: some box no longer contains its child.
            let inward = compress(bvh.nodes(), bvh.prim_order(), Rounding::Inward).unwrap();
            let e = check(bvh.nodes(), bvh.prim_order(), &inward).expect_err(name);
            assert!(e.contains("does not contain"), "{name}: {e}");
        }
    }

    #[test]
    fn the_collapse_fills_most_slots() {
        let scene = reference::load_scene("rtow-final").unwrap();
        let bvh = scene.bvh();
        let c = compress(bvh.nodes(), bvh.prim_order(), Rounding::Outward).unwrap();
        let live: usize = c
            .nodes
            .iter()
            .map(|n| (0..WIDTH).filter(|&s| n.is_live(s)).count())
            .sum();
        // 570 children on 106 nodes (5.4 a node; a binary node holds 2):
        // leaves of one or two spheres under nodes of a few children are
        // cheaper than more nodes.
        assert!(
            live >= 5 * c.nodes.len(),
            "{live} children on {} nodes",
            c.nodes.len()
        );
    }

    #[test]
    fn quantized_bounds_are_the_tightest_that_contain() {
        // Two children on [1, 2] and [1.5, 3]: p = 1, and 255 · 2^e ≥ 2
        // needs e = -6 (255 · 2^-7 = 1.99).
        let (p, e, q) = quantize(&[(1.0, 2.0), (1.5, 3.0)], Rounding::Outward).unwrap();
        assert_eq!((p, e), (1.0, -6));
        assert_eq!(q, vec![(0, 64), (32, 128)]);
        // A bound between grid points: down for a minimum, up for a maximum.
        let (_, e, q) = quantize(&[(0.0, 255.0), (1.1, 2.1)], Rounding::Outward).unwrap();
        assert_eq!(e, 0);
        assert_eq!(q[1], (1, 3));
        let (_, _, q) = quantize(&[(0.0, 255.0), (1.1, 2.1)], Rounding::Inward).unwrap();
        assert_eq!(q[1], (2, 2));
        // Zero extent: the least exponent, every byte 0.
        let (p, e, q) = quantize(&[(-3.5, -3.5)], Rounding::Outward).unwrap();
        assert_eq!((p, e as i32, q), (-3.5, EXPONENT_MIN, vec![(0, 0)]));
        // A subnormal minimum: the origin is the least normal below it.
        let tiny = -f32::from_bits(5);
        let (p, e, q) = quantize(&[(tiny, 1.0)], Rounding::Outward).unwrap();
        assert_eq!(p, -f32::MIN_POSITIVE);
        assert!(dequantize(p, e, q[0].0) <= tiny);
        // Far from the origin the f32 sum rounds: still outward.
        let (lo, hi) = (1.0e7f32, 1.0e7f32 + 1.0);
        let (p, e, q) = quantize(&[(lo - 3000.0, lo), (lo, hi)], Rounding::Outward).unwrap();
        assert!(dequantize(p, e, q[1].0) <= lo && dequantize(p, e, q[1].1) >= hi);
        // Not finite, or too wide for 255 · 2^119: refused.
        assert!(quantize(&[(0.0, f32::INFINITY)], Rounding::Outward).is_err());
        assert!(quantize(&[(f32::NAN, 1.0)], Rounding::Outward).is_err());
        assert!(quantize(&[(-f32::MAX, f32::MAX)], Rounding::Outward).is_err());
    }

    #[test]
    fn the_corner_a_ray_comes_from_takes_the_first_slot() {
        // Eight unit boxes at the corners of a cube: bit k of a slot set
        // for a child on the negative side of axis k.
        let at = |c: [f32; 3]| BvhNode {
            min: c,
            index: 0,
            max: c.map(|x| x + 1.0),
            meta: (1 << 2) | BvhNode::LEAF,
        };
        let parent = BvhNode {
            min: [-10.0; 3],
            index: 0,
            max: [11.0; 3],
            meta: 0,
        };
        let corners: Vec<BvhNode> = (0..8)
            .map(|i| at([0, 1, 2].map(|k| if (i >> k) & 1 == 1 { -10.0 } else { 10.0 })))
            .collect();
        let refs: Vec<&BvhNode> = corners.iter().rev().collect();
        let slots = assign_slots(&parent, &refs);
        for (s, slot) in slots.iter().enumerate() {
            assert_eq!(*slot, Some(7 - s), "slot {s}");
        }
    }

    #[test]
    fn leaves_too_big_and_stacks_too_deep_are_refused() {
        let leaf = |first: u32, count: u32, x: f32| BvhNode {
            min: [x; 3],
            index: first,
            max: [x + 1.0; 3],
            meta: (count << 2) | BvhNode::LEAF,
        };
        // A leaf of 8 entries: the meta byte holds 7.
        let e = compress(&[leaf(0, 8, 0.0)], &[0; 8], Rounding::Outward).unwrap_err();
        assert!(e.contains("1 to 7 entries"), "{e}");
        assert!(compress(&[leaf(0, 7, 0.0)], &[0; 7], Rounding::Outward).is_ok());
        assert!(compress(&[], &[], Rounding::Outward).is_err());
        // A comb: a spine whose every left child is a full tree of 16
        // leaves (too many for one node's lanes), so that every wide node
        // on the spine has two interior children and defers one group.
        let comb = |len: usize| {
            let mut nodes = Vec::new();
            let mut leaves = 0u32;
            fn full(nodes: &mut Vec<BvhNode>, leaves: &mut u32, depth: u32, x: f32) {
                let at = nodes.len();
                if depth == 0 {
                    nodes.push(BvhNode {
                        min: [x; 3],
                        index: *leaves,
                        max: [x + 1.0; 3],
                        meta: (1 << 2) | BvhNode::LEAF,
                    });
                    *leaves += 1;
                    return;
                }
                let half = (1 << (depth - 1)) as f32;
                nodes.push(BvhNode {
                    min: [x; 3],
                    index: 0,
                    max: [x + 2.0 * half; 3],
                    meta: 0,
                });
                full(nodes, leaves, depth - 1, x);
                nodes[at].index = nodes.len() as u32;
                full(nodes, leaves, depth - 1, x + half);
            }
            for i in 0..len {
                let at = nodes.len();
                let x = 20.0 * i as f32;
                nodes.push(BvhNode {
                    min: [x; 3],
                    index: 0,
                    max: [20.0 * len as f32 + 1.0; 3],
                    meta: 0,
                });
                full(&mut nodes, &mut leaves, 4, x);
                nodes[at].index = nodes.len() as u32;
            }
            nodes.push(BvhNode {
                min: [20.0 * len as f32; 3],
                index: leaves,
                max: [20.0 * len as f32 + 1.0; 3],
                meta: (1 << 2) | BvhNode::LEAF,
            });
            let order: Vec<u32> = (0..=leaves).collect();
            (nodes, order)
        };
        // The collapse gives each wide node on the spine seven full trees
        // and the spine's rest: one more deferred group every seven spine
        // nodes.
        let (nodes, order) = comb(30);
        let c = compress(&nodes, &order, Rounding::Outward).unwrap();
        check(&nodes, &order, &c).unwrap();
        assert!(stack_need(&c.nodes) >= 4, "{}", stack_need(&c.nodes));
        let (nodes, order) = comb(1000);
        let e = compress(&nodes, &order, Rounding::Outward).unwrap_err();
        assert!(e.contains("more than its stack's 64"), "{e}");
    }
}
