//! The CPU traversal's 8-wide view of the binary tree: the collapse plan
//! and the wide nodes it fills.

use super::node::BvhNode;

/// Most batched primitives
/// ([`Bvh::build_batched`](super::Bvh::build_batched)) one leaf test
/// takes.
pub const LEAF_BATCH: usize = 4;

/// Children per collapsed node; a multiple of 4 (boxes are tested four
/// at a time, see [`NodeSlabs::test_wide`]) and a power of two (lane
/// numbers from a mask's bits are masked with `WIDTH - 1`).
pub(super) const WIDTH: usize = 8;

const _: () = assert!(WIDTH % 4 == 0 && WIDTH.is_power_of_two() && WIDTH <= 32);

/// Up to [`WIDTH`] children of a collapsed node, boxes in SoA form so that
/// one step tests them all with the same arithmetic as [`NodeSlabs`] on
/// each (lane by lane, no fused operations: the same bits), the layout of
/// Embree's BVH4/BVH8 and of Wald et al., "Getting Rid of Packets" (2008),
/// built as they do by collapsing the binary tree, here as the surface-area
/// cost model says is cheapest ([`CollapsePlan`]). Every lane is a binary
/// node with its box bit for bit: the interior nodes in between are
/// skipped, and in a batched build
/// ([`Bvh::build_batched`](super::Bvh::build_batched)) a small subtree may
/// become one leaf lane, the run of its entries under its root's box.
/// `bounds` rows are min x, y, z
/// then max x, y, z (the words `NodeSlabs` picks by ray direction).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct WideNode {
    pub(super) bounds: [[f32; WIDTH]; 6],
    /// Interior lane: index into `wide`. Leaf lane: index into
    /// `leaf_ranges`. Empty lane: 0.
    pub(super) child: [u32; WIDTH],
    /// A binary node's `meta` (leaf: `count << 2 | 3`, the count of the
    /// whole subtree where the collapse made it one leaf; interior: its
    /// axis); [`WideNode::EMPTY`] for an unused lane.
    pub(super) meta: [u32; WIDTH],
}

impl WideNode {
    pub(super) const EMPTY: u32 = u32::MAX;
    /// Empty lanes have the inverted infinite box (min +∞, max −∞): every
    /// slab then gives `t_near = +∞` and `t_far = −∞` (never a NaN: the
    /// bound minus a finite origin is infinite, times a nonzero or infinite
    /// inverse direction), so the box test fails without a check of its own.
    pub(super) const NONE: WideNode = WideNode {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
        meta: [Self::EMPTY; WIDTH],
    };

    pub(super) fn set(&mut self, lane: usize, n: &BvhNode, child: u32) {
        for k in 0..3 {
            self.bounds[k][lane] = n.min[k];
            self.bounds[3 + k][lane] = n.max[k];
        }
        self.child[lane] = child;
        self.meta[lane] = n.meta;
    }

    /// The lane as a binary node (for tests).
    #[cfg(test)]
    pub(super) fn lane(&self, lane: usize) -> BvhNode {
        BvhNode {
            min: [0, 1, 2].map(|k| self.bounds[k][lane]),
            max: [0, 1, 2].map(|k| self.bounds[3 + k][lane]),
            index: self.child[lane],
            meta: self.meta[lane],
        }
    }
}

/// Relative cost of visiting a wide node (its lanes' box tests and the
/// bookkeeping) and of one primitive test, for [`CollapsePlan`]. Measured
/// on reference/benches/traversal.rs's 10^4-triangle torus (an instrumented
/// run and `perf record`, docs/benchmarks.md): about 47 ns per wide-node
/// visit and 54 ns per triangle test with its load, so taken as equal;
/// node costs of 0.5, 2 and 4 were no faster there. A four-wide triangle
/// test counts as one test: costing it 0.7, 1.5 or 2 made the 5,120- and
/// 20,480-triangle spheres and that torus no faster (docs/benchmarks.md).
pub(super) const COLLAPSE_NODE_COST: f32 = 1.0;

pub(super) const COLLAPSE_PRIM_COST: f32 = 1.0;

/// Which binary nodes become the lanes of each wide node: the collapse
/// with the least surface-area cost Σ A(wide node)·C_node + Σ A(leaf)·
/// tests·C_prim over the whole tree, by dynamic programming over the binary
/// tree (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on
/// GPUs Through Compressed Wide BVHs", HPG 2017, §3.1). A leaf costs one
/// test per entry, or one in all if its entries are batched (tested up to
/// [`LEAF_BATCH`] at a time); an interior node below the root whose
/// subtree's entries are one run of at most [`LEAF_BATCH`] batched ones may
/// also become one leaf, the choice Embree's builders make when they fill
/// triangle4 leaves. The greedy collapse it replaces (open the largest
/// interior child until eight lanes) left the wide nodes of small subtrees
/// half empty: 3.74 lanes per node on the 10^4-triangle torus, 6.03 now.
pub(super) struct CollapsePlan {
    /// `split[n][j - 1]`: how subtree `n` fills at most `j` lanes: 0 for
    /// one lane (a leaf, or a wide node of its own, or a leaf of the whole
    /// subtree), else `k`, the lanes given to the left child (the right
    /// child gets at most `j - k`).
    split: Vec<[u8; WIDTH]>,
    /// The `k` of interior node `n`'s own wide node (its children share
    /// [`WIDTH`] lanes); 0 where one lane holds the whole subtree as a
    /// leaf.
    own: Vec<u8>,
}

impl CollapsePlan {
    /// The plan for `nodes`; `batched` as for
    /// [`Bvh::build_batched`](super::Bvh::build_batched).
    pub(super) fn new(nodes: &[BvhNode], prim_order: &[u32], batched: &[bool]) -> Self {
        let mut plan = CollapsePlan {
            split: vec![[0u8; WIDTH]; nodes.len()],
            own: vec![0u8; nodes.len()],
        };
        if !nodes.is_empty() {
            let batched = |entries: std::ops::Range<usize>| {
                !entries.is_empty()
                    && prim_order[entries]
                        .iter()
                        .all(|&p| batched.get(p as usize) == Some(&true))
            };
            plan.solve(nodes, 0, &batched);
        }
        plan
    }

    /// Plans subtree `n` and returns, for each j, the least cost of it in
    /// at most j lanes (post-order, so only one cost row per level of the
    /// tree is alive: 9 bytes of plan per node, not 41).
    /// Also returns the subtree's entries as `(first, count)` if they are
    /// one run of batched primitives, short enough for one leaf.
    fn solve(
        &mut self,
        nodes: &[BvhNode],
        n: usize,
        batched: &impl Fn(std::ops::Range<usize>) -> bool,
    ) -> ([f32; WIDTH], Option<(u32, u32)>) {
        let node = &nodes[n];
        let area = node.bounds().surface_area();
        if node.is_leaf() {
            let (first, count) = (node.index, node.count());
            let batch = (count as usize <= LEAF_BATCH
                && batched(first as usize..(first + count) as usize))
            .then_some((first, count));
            // A batched leaf is one four-wide test, another one test per
            // entry.
            let tests = if batch.is_some() { 1 } else { count };
            return ([area * tests as f32 * COLLAPSE_PRIM_COST; WIDTH], batch);
        }
        let (left, left_span) = self.solve(nodes, n + 1, batched);
        let (right, right_span) = self.solve(nodes, node.index as usize, batched);
        // The entries of the whole subtree, if they are one run of batched
        // primitives short enough for a leaf.
        let span = match (left_span, right_span) {
            (Some((a, m)), Some((b, k)))
                if a.checked_add(m) == Some(b) && (m + k) as usize <= LEAF_BATCH =>
            {
                Some((a, m + k))
            }
            _ => None,
        };
        // The cheapest way to spread both children over at most j lanes
        // (the first k on ties).
        let pair = |j: usize| {
            (1..j)
                .map(|k| (left[k - 1] + right[j - k - 1], k))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap_or((f32::INFINITY, 0))
        };
        let (children, k_own) = pair(WIDTH);
        let mut as_node = area * COLLAPSE_NODE_COST + children;
        self.own[n] = k_own as u8;
        // (The root is always a wide node: the traversal starts there.)
        if span.is_some() && n != 0 {
            let as_leaf = area * COLLAPSE_PRIM_COST;
            if as_leaf <= as_node {
                (as_node, self.own[n]) = (as_leaf, 0);
            }
        }
        let mut cost = [as_node; WIDTH];
        for j in 2..=WIDTH {
            let (c, k) = pair(j);
            if c < as_node {
                (cost[j - 1], self.split[n][j - 1]) = (c, k as u8);
            }
        }
        (cost, span)
    }

    /// Appends, in depth-first order, the lanes that subtree `n` fills
    /// when given at most `j`.
    fn lanes(&self, nodes: &[BvhNode], n: usize, j: usize, out: &mut Vec<usize>) {
        match self.split[n][j - 1] as usize {
            0 => out.push(n),
            k => {
                self.lanes(nodes, n + 1, k, out);
                self.lanes(nodes, nodes[n].index as usize, j - k, out);
            }
        }
    }
}

/// Collapses binary interior node `i` into a new [`WideNode`] (and its
/// subtree after it) as `plan` says, and returns the new node's index and
/// its subtree's stack need (see [`Bvh`](super::Bvh)'s `stack_need`).
pub(super) fn collapse(
    nodes: &[BvhNode],
    plan: &CollapsePlan,
    i: usize,
    wide: &mut Vec<WideNode>,
    leaves: &mut Vec<[u32; 2]>,
) -> (u32, usize) {
    let mut kids = Vec::with_capacity(WIDTH);
    let k = plan.own[i] as usize;
    plan.lanes(nodes, i + 1, k, &mut kids);
    plan.lanes(nodes, nodes[i].index as usize, WIDTH - k, &mut kids);
    let n = kids.len();
    let at = wide.len();
    wide.push(WideNode::NONE);
    let mut below = 0;
    for (lane, &c) in kids.iter().enumerate() {
        let mut node = nodes[c];
        let child = if node.is_leaf() || plan.own[c] == 0 {
            // A leaf, or a subtree the plan made one (its entries are one
            // run).
            let (first, count) = leaf_span(nodes, c);
            node.meta = (count << 2) | BvhNode::LEAF;
            leaves.push([first, count]);
            leaves.len() as u32 - 1
        } else {
            let (child, need) = collapse(nodes, plan, c, wide, leaves);
            below = below.max(need);
            child
        };
        wide[at].set(lane, &node, child);
    }
    (at as u32, n - 1 + below)
}

/// The first entry and the entry count of subtree `n`, whose leaves the
/// plan found to be one run.
pub(super) fn leaf_span(nodes: &[BvhNode], n: usize) -> (u32, u32) {
    let node = &nodes[n];
    if node.is_leaf() {
        return (node.index, node.count());
    }
    let (first, left) = leaf_span(nodes, n + 1);
    let (_, right) = leaf_span(nodes, node.index as usize);
    (first, left + right)
}
