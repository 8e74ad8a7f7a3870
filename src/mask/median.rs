//! The w×w median filter of the mask's first step (w odd, 3 ≤ w ≤ 7), borders clamped to the
//! edge: a window that reaches past the image reads the nearest edge pixel, as NumPy's
//! `np.pad(mode="edge")` and OpenCV's `BORDER_REPLICATE` do.
//!
//! Why a generated network: a median of 49 floats per pixel by `select_nth_unstable` costs
//! hundreds of unpredictable branches per pixel. Instead every output row is computed with
//! branch-free min/max operations on whole row slices (which the compiler vectorises):
//! 1. each column of the w input rows is sorted once (a small sorting network) and shared by the
//!    w windows that contain it;
//! 2. two horizontally adjacent windows share w − 1 sorted columns: those are merged once, as
//!    the presorted groups of Batcher's odd-even merge sort on 64 wires (groups of 8, the
//!    missing values +∞), so only its merge phases remain; they are simulated symbolically
//!    once, comparators touching +∞ are dropped;
//! 3. each of the two medians is then selected from that merged list and its own column with
//!    the order-statistic identity in [`MedianNetwork::new`], and only the min/max operations
//!    the two medians depend on are kept: 184 per pixel for w = 7 (80 for w = 5), where one
//!    window at a time needed 372 (152).

use rayon::prelude::*;

/// Pixel pairs per chunk: the network's working set (slots × CHUNK floats) stays in L1/L2.
const CHUNK: usize = 64;
/// Wires of the Batcher network and the size of its presorted groups (one group per column).
const WIRES: usize = 64;
const GROUP: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Node {
    /// Rank `r` of window column `c` (columns presorted ascending).
    Leaf {
        c: u8,
        r: u8,
    },
    Inf,
    Min(u32, u32),
    Max(u32, u32),
}

/// One straight-line operation on chunk-wide slots: `dst = min/max(a, b)`.
#[derive(Clone, Copy, Debug)]
struct Op {
    max: bool,
    a: u16,
    b: u16,
    dst: u16,
}

/// The pruned median network for one window size, ready to run on row slices.
#[derive(Debug)]
pub struct MedianNetwork {
    w: usize,
    ops: Vec<Op>,
    /// Leaf (column, rank) loaded into each of the first slots.
    leaves: Vec<(u8, u8)>,
    slots: usize,
    /// The slots of the left and the right median.
    out: [u16; 2],
}

/// Batcher's odd-even merge sort comparators for `WIRES` wires, merge phases from group size
/// `GROUP` up (the phases below only sort within groups, which the presorted columns already are).
fn batcher_merge_phases() -> Vec<(usize, usize)> {
    let mut cmp = Vec::new();
    let mut p = GROUP;
    while p < WIRES {
        let mut k = p;
        while k >= 1 {
            let mut j = k % p;
            while j + k < WIRES {
                for i in 0..k.min(WIRES - j - k) {
                    if (i + j) / (2 * p) == (i + j + k) / (2 * p) {
                        cmp.push((i + j, i + j + k));
                    }
                }
                j += 2 * k;
            }
            k /= 2;
        }
        p *= 2;
    }
    cmp
}

impl MedianNetwork {
    /// Build the network for a `w`×`w` window (odd, 3..=7). It computes two horizontally
    /// adjacent medians at once, over the w + 1 columns `0..=w`: the w − 1 columns both windows
    /// share are merged once (Batcher), then each median is selected from that sorted list A
    /// and its own column B by the order-statistic identity
    /// `k-th of A ∪ B = min_{i+j=k+1} max(A[i−1], B[j−1])` (an empty prefix counts as −∞):
    /// every split of the first k + 1 values bounds the k-th from above, and the split the
    /// merged order makes attains it. Only the ranks of A that identity reads are kept.
    pub fn new(w: usize) -> MedianNetwork {
        assert!(
            w % 2 == 1 && (3..=7).contains(&w),
            "median window must be odd and 3..=7"
        );
        let mut nodes: Vec<Node> = Vec::new();
        let push = |nodes: &mut Vec<Node>, n: Node| {
            nodes.push(n);
            (nodes.len() - 1) as u32
        };
        // The shared columns 1..w sit in the network's first w − 1 groups.
        let mut wires: Vec<u32> = Vec::with_capacity(WIRES);
        for g in 0..WIRES / GROUP {
            for r in 0..GROUP {
                let node = if g + 1 < w && r < w {
                    Node::Leaf {
                        c: (g + 1) as u8,
                        r: r as u8,
                    }
                } else {
                    Node::Inf
                };
                wires.push(push(&mut nodes, node));
            }
        }
        for (i, j) in batcher_merge_phases() {
            let (a, b) = (wires[i], wires[j]);
            match (nodes[a as usize], nodes[b as usize]) {
                (_, Node::Inf) => {}
                (Node::Inf, _) => wires.swap(i, j),
                _ => {
                    wires[i] = push(&mut nodes, Node::Min(a, b));
                    wires[j] = push(&mut nodes, Node::Max(a, b));
                }
            }
        }
        let k = (w * w - 1) / 2;
        let outs = [0, w].map(|c| {
            let mut acc = wires[k];
            for j in 1..=w {
                let b = push(
                    &mut nodes,
                    Node::Leaf {
                        c: c as u8,
                        r: (j - 1) as u8,
                    },
                );
                let term = push(&mut nodes, Node::Max(wires[k - j], b));
                acc = push(&mut nodes, Node::Min(acc, term));
            }
            acc
        });
        // Keep only what the medians depend on.
        let mut live = vec![false; nodes.len()];
        for o in outs {
            live[o as usize] = true;
        }
        for id in (0..nodes.len()).rev() {
            if live[id]
                && let Node::Min(a, b) | Node::Max(a, b) = nodes[id]
            {
                live[a as usize] = true;
                live[b as usize] = true;
            }
        }
        // The outputs are used at the very end, after every op.
        let mut last_use = vec![0usize; nodes.len()];
        for (id, n) in nodes.iter().enumerate() {
            if live[id]
                && let Node::Min(a, b) | Node::Max(a, b) = n
            {
                last_use[*a as usize] = id;
                last_use[*b as usize] = id;
            }
        }
        for o in outs {
            last_use[o as usize] = usize::MAX;
        }
        // Slot allocation: leaves first, then each result takes a free slot; inputs are freed
        // after the destination is chosen so an op never writes a slot it reads.
        let mut slot_of = vec![u16::MAX; nodes.len()];
        let mut leaves = Vec::new();
        for (id, n) in nodes.iter().enumerate() {
            if let (true, Node::Leaf { c, r }) = (live[id], n) {
                slot_of[id] = leaves.len() as u16;
                leaves.push((*c, *r));
            }
        }
        let mut slots = leaves.len();
        let mut free: Vec<u16> = Vec::new();
        let mut ops = Vec::new();
        for id in 0..nodes.len() {
            let (max, a, b) = match nodes[id] {
                Node::Min(a, b) if live[id] => (false, a, b),
                Node::Max(a, b) if live[id] => (true, a, b),
                _ => continue,
            };
            let dst = free.pop().unwrap_or_else(|| {
                slots += 1;
                (slots - 1) as u16
            });
            slot_of[id] = dst;
            ops.push(Op {
                max,
                a: slot_of[a as usize],
                b: slot_of[b as usize],
                dst,
            });
            for x in [a, b] {
                if last_use[x as usize] == id {
                    free.push(slot_of[x as usize]);
                }
            }
        }
        MedianNetwork {
            w,
            ops,
            leaves,
            slots,
            out: outs.map(|o| slot_of[o as usize]),
        }
    }

    /// Number of min/max operations per pixel (excluding the shared column sort).
    pub fn ops_per_pixel(&self) -> f64 {
        self.ops.len() as f64 / 2.0
    }

    /// Median-filter a `width`×`height` image (row-major), borders clamped to the edge.
    pub fn apply(&self, src: &[f32], width: usize, height: usize) -> Vec<f32> {
        assert_eq!(src.len(), width * height);
        let mut dst = vec![0.0f32; src.len()];
        if src.is_empty() {
            return dst;
        }
        dst.par_chunks_mut(width).enumerate().for_each_init(
            || RowScratch::new(self, width),
            |scratch, (y, out)| self.row_dispatch(src, width, height, y, scratch, out),
        );
        dst
    }

    /// The row with 8-wide AVX2 min/max where the CPU has them (the build targets baseline
    /// x86-64, whose SSE2 gives 4 lanes): the same code, compiled twice.
    fn row_dispatch(
        &self,
        src: &[f32],
        width: usize,
        height: usize,
        y: usize,
        s: &mut RowScratch,
        out: &mut [f32],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { self.row_avx2(src, width, height, y, s, out) };
            return;
        }
        self.row(src, width, height, y, s, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn row_avx2(
        &self,
        src: &[f32],
        width: usize,
        height: usize,
        y: usize,
        s: &mut RowScratch,
        out: &mut [f32],
    ) {
        self.row(src, width, height, y, s, out)
    }

    #[inline(always)]
    fn row(
        &self,
        src: &[f32],
        width: usize,
        height: usize,
        y: usize,
        s: &mut RowScratch,
        out: &mut [f32],
    ) {
        let (w, h) = (self.w, self.w / 2);
        // Clamped input rows, each padded left and right with its edge pixel.
        let half = s.half;
        for (r, padded) in s.cols.chunks_mut(2 * half).enumerate() {
            let sy = (y + r).saturating_sub(h).min(height - 1);
            let row = &src[sy * width..(sy + 1) * width];
            padded[..h].fill(row[0]);
            padded[h..h + width].copy_from_slice(row);
            padded[h + width..].fill(row[width - 1]);
        }
        // Lane i computes the pixels 2i and 2i + 1 of a chunk, so the rows are split by
        // parity, `split[p][r][m]` = padded row r's value 2m + p, and then column-sorted.
        let (even, odd) = s.split.split_at_mut(w * half);
        for ((padded, e), o) in s
            .cols
            .chunks(2 * half)
            .zip(even.chunks_mut(half))
            .zip(odd.chunks_mut(half))
        {
            for ((pair, e), o) in padded.chunks_exact(2).zip(e).zip(o) {
                *e = pair[0];
                *o = pair[1];
            }
        }
        for parity in s.split.chunks_mut(w * half) {
            sort_columns(parity, half, w);
        }
        let pairs = width.div_ceil(2);
        for m0 in (0..pairs).step_by(CHUNK) {
            let n = CHUNK.min(pairs - m0);
            for (slot, &(c, r)) in s.slots.chunks_mut(CHUNK).zip(&self.leaves) {
                let (c, r) = (c as usize, r as usize);
                let start = ((c % 2) * w + r) * half + m0 + c / 2;
                slot[..n].copy_from_slice(&s.split[start..start + n]);
            }
            for op in &self.ops {
                let [d, a, b] = match s.slots_as_chunks().get_disjoint_mut([
                    op.dst as usize,
                    op.a as usize,
                    op.b as usize,
                ]) {
                    Ok(v) => v,
                    Err(_) => unreachable!("network slots are distinct by construction"),
                };
                if op.max {
                    for ((d, a), b) in d.iter_mut().zip(a.iter()).zip(b.iter()) {
                        *d = if a > b { *a } else { *b };
                    }
                } else {
                    for ((d, a), b) in d.iter_mut().zip(a.iter()).zip(b.iter()) {
                        *d = if a < b { *a } else { *b };
                    }
                }
            }
            let [o0, o1] = self.out.map(|o| o as usize * CHUNK);
            let dst = &mut out[2 * m0..(2 * (m0 + n)).min(width)];
            for (i, px) in dst.chunks_mut(2).enumerate() {
                px[0] = s.slots[o0 + i];
                if let Some(right) = px.get_mut(1) {
                    *right = s.slots[o1 + i];
                }
            }
        }
    }
}

/// Per-thread buffers: the w padded, column-sorted input rows, the same split by parity, and
/// the network's slots.
struct RowScratch {
    /// Length of one parity half of a row: the pairs plus the window's reach past them.
    half: usize,
    cols: Vec<f32>,
    split: Vec<f32>,
    slots: Vec<f32>,
}

impl RowScratch {
    fn new(net: &MedianNetwork, width: usize) -> RowScratch {
        let half = width.div_ceil(2) + net.w / 2;
        RowScratch {
            half,
            cols: vec![0.0; 2 * net.w * half],
            split: vec![0.0; 2 * net.w * half],
            slots: vec![0.0; net.slots * CHUNK],
        }
    }

    fn slots_as_chunks(&mut self) -> &mut [[f32; CHUNK]] {
        self.slots.as_chunks_mut::<CHUNK>().0
    }
}

/// Sort every column of `w` rows (each `len` long) ascending, top row = smallest, with an
/// odd-even transposition network on whole rows (w steps; branch-free, vectorised).
#[inline(always)]
fn sort_columns(rows: &mut [f32], len: usize, w: usize) {
    for step in 0..w {
        for i in (step % 2..w.saturating_sub(1)).step_by(2) {
            let (lo, hi) = rows[i * len..(i + 2) * len].split_at_mut(len);
            for (a, b) in lo.iter_mut().zip(hi.iter_mut()) {
                let (x, y) = (*a, *b);
                *a = x.min(y);
                *b = x.max(y);
            }
        }
    }
}

/// The same filter by brute force (copy the window, select the middle): the reference the fast
/// network is tested against.
pub fn median_reference(src: &[f32], width: usize, height: usize, w: usize) -> Vec<f32> {
    let h = (w / 2) as isize;
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut out = vec![0.0; src.len()];
    let mut win = Vec::with_capacity(w * w);
    for y in 0..height {
        for x in 0..width {
            win.clear();
            for dy in -h..=h {
                for dx in -h..=h {
                    win.push(
                        src[clamp(y as isize + dy, height) * width + clamp(x as isize + dx, width)],
                    );
                }
            }
            let mid = win.len() / 2;
            out[y * width + x] = *win.select_nth_unstable_by(mid, f32::total_cmp).1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::mix64;

    fn noise_image(width: usize, height: usize, seed: u64) -> Vec<f32> {
        (0..width * height)
            .map(|i| {
                let v = (mix64(seed ^ (i as u64)) >> 40) as f32 / (1u64 << 24) as f32;
                // Few distinct values too, so ties are exercised.
                if i % 7 == 0 {
                    (v * 4.0).floor()
                } else {
                    v * v * 10.0
                }
            })
            .collect()
    }

    #[test]
    fn network_matches_brute_force() {
        for w in [3, 5, 7] {
            let net = MedianNetwork::new(w);
            for (width, height) in [(1, 1), (2, 3), (9, 4), (130, 11), (257, 3)] {
                let img = noise_image(width, height, (w * 1000 + width) as u64);
                assert_eq!(
                    net.apply(&img, width, height),
                    median_reference(&img, width, height, w),
                    "w={w} {width}x{height}"
                );
            }
        }
    }

    #[test]
    fn network_is_small() {
        // The point of the pruning and the pairing: the merge phases of a 64-wire Batcher sort
        // have 391 comparators (782 min/max); one 7×7 window alone needs 372 of them, two
        // adjacent windows sharing six columns 184 per pixel.
        let (n7, n5) = (
            MedianNetwork::new(7).ops_per_pixel(),
            MedianNetwork::new(5).ops_per_pixel(),
        );
        assert!(n7 <= 184.0 && n5 <= 80.0, "w=7: {n7}, w=5: {n5}");
    }
}
