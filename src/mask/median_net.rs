//! The symbolic median network behind [`super::median`], shared with `build.rs`, which turns it
//! into straight-line code (a macro per window size), and with the tests, which check its size.
//! It uses nothing outside this file, so the build script can include it as a module.
//!
//! The network computes a 2×2 tile of w×w medians at once (after Adams 2021, "Fast median
//! filters using separable sorting networks"), over the w + 1 rows and columns the four windows
//! span. All four hold the w − 1 middle rows of the w − 1 middle columns; each column's middle
//! rows come presorted ascending (rank 0 = smallest), the top and bottom rows' values unsorted.
//! 1. The shared middle columns are merged once, as the presorted groups of Batcher's odd-even
//!    merge sort on 64 wires (groups of 8, the missing values +∞), so only its merge phases
//!    remain; comparators touching +∞ are dropped. Each tile row's extra row is merged alike.
//! 2. Lists are joined by the order-statistic identity `k-th of A ∪ B = min_{i+j=k+1}
//!    max(A[i−1], B[j−1])` (an empty prefix counts as −∞): every split of the first k + 1 values
//!    bounds the k-th from above, and the split the merged order makes attains it. Each tile
//!    column joins its own column's middle rows (only the ranks the median can need), each tile
//!    row its own column's extra value, and each median the two.
//! 3. Only the min/max operations the four medians depend on are kept: 163.5 per pixel for
//!    w = 7 (75.5 for w = 5), where pairs of adjacent medians in one row need 184 (80) and one
//!    window at a time 372 (152).

/// Wires of the Batcher network and the size of its presorted groups (one group per column).
const WIRES: usize = 64;
const GROUP: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Node {
    /// Rank `r` of window column `c`.
    Leaf {
        c: u8,
        r: u8,
    },
    Inf,
    Min(u32, u32),
    Max(u32, u32),
}

/// One kept value of the network, in an order where every operand comes first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// Rank `r` of window column `c`.
    Leaf { c: u8, r: u8 },
    /// The smaller (`max: false`) or larger of two earlier values.
    MinMax { max: bool, a: u32, b: u32 },
}

/// The pruned network for one window size: `values` in evaluation order, `out` the indices of
/// the medians.
#[derive(Clone, Debug)]
pub struct Network {
    pub values: Vec<Value>,
    pub out: Vec<u32>,
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

/// Builds a network node by node; `finish` keeps what the outputs depend on.
struct Builder {
    nodes: Vec<Node>,
}

impl Builder {
    fn push(&mut self, n: Node) -> u32 {
        self.nodes.push(n);
        (self.nodes.len() - 1) as u32
    }

    fn leaf(&mut self, c: usize, r: usize) -> u32 {
        self.push(Node::Leaf {
            c: c as u8,
            r: r as u8,
        })
    }

    /// The sorted union of at most `WIRES / GROUP` sorted groups of at most `GROUP` values, by
    /// the merge phases of Batcher's sort (missing values are +∞, and comparators touching them
    /// are dropped).
    fn merge(&mut self, groups: &[Vec<u32>]) -> Vec<u32> {
        let inf = self.push(Node::Inf);
        let mut wires: Vec<u32> = (0..WIRES)
            .map(|i| {
                let (g, r) = (i / GROUP, i % GROUP);
                groups.get(g).and_then(|g| g.get(r)).copied().unwrap_or(inf)
            })
            .collect();
        for (i, j) in batcher_merge_phases() {
            let (a, b) = (wires[i], wires[j]);
            match (self.nodes[a as usize], self.nodes[b as usize]) {
                (_, Node::Inf) => {}
                (Node::Inf, _) => wires.swap(i, j),
                _ => {
                    wires[i] = self.push(Node::Min(a, b));
                    wires[j] = self.push(Node::Max(a, b));
                }
            }
        }
        wires.truncate(groups.iter().map(Vec::len).sum());
        wires
    }

    /// The value of rank `k` (0 = smallest) of the union of the sorted lists `a` and `b`, by
    /// the order-statistic identity of the module docs.
    fn kth(&mut self, a: &[u32], b: &[u32], k: usize) -> u32 {
        let mut acc: Option<u32> = None;
        for j in 0..=b.len() {
            let Some(i) = (k + 1).checked_sub(j).filter(|&i| i <= a.len()) else {
                continue;
            };
            let term = match (i, j) {
                (_, 0) => a[i - 1],
                (0, _) => b[j - 1],
                _ => self.push(Node::Max(a[i - 1], b[j - 1])),
            };
            acc = Some(match acc {
                None => term,
                Some(acc) => self.push(Node::Min(acc, term)),
            });
        }
        acc.expect("k < a.len() + b.len()")
    }

    /// The network of `outs`: only what they depend on, renumbered in the same order.
    fn finish(self, outs: Vec<u32>) -> Network {
        let nodes = self.nodes;
        let mut live = vec![false; nodes.len()];
        for &o in &outs {
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
        let mut index = vec![u32::MAX; nodes.len()];
        let mut values = Vec::new();
        for (id, n) in nodes.iter().enumerate() {
            if !live[id] {
                continue;
            }
            index[id] = values.len() as u32;
            values.push(match *n {
                Node::Leaf { c, r } => Value::Leaf { c, r },
                Node::Min(a, b) | Node::Max(a, b) => Value::MinMax {
                    max: matches!(n, Node::Max(..)),
                    a: index[a as usize],
                    b: index[b as usize],
                },
                Node::Inf => unreachable!("+inf operands were dropped"),
            });
        }
        Network {
            values,
            out: outs.iter().map(|&o| index[o as usize]).collect(),
        }
    }
}

impl Network {
    /// The 2×2 tile network for a `w`×`w` window (odd, 3..=7) over the w + 1 rows and columns
    /// of four windows: leaf (c, r) of column c (0..=w) is, for r < w − 1, rank r of the w − 1
    /// middle rows (which all four windows hold; presorted), for r = w − 1 the top row's value
    /// and for r = w the bottom row's. The middle rows' shared w − 1 columns are merged once;
    /// each tile row's w − 1 shared extra values are merged once and joined by its own column's
    /// extra value; each tile column's merged list is joined by its own column's middle values.
    /// Outputs: top-left, top-right, bottom-left, bottom-right. (After Adams 2021, "Fast median
    /// filters using separable sorting networks": tiles of outputs share their sorted core.)
    pub fn tile(w: usize) -> Network {
        assert!(
            w % 2 == 1 && (3..=7).contains(&w),
            "median window must be odd and 3..=7"
        );
        let mut b = Builder { nodes: Vec::new() };
        let core: Vec<Vec<u32>> = (0..=w)
            .map(|c| (0..w - 1).map(|r| b.leaf(c, r)).collect())
            .collect();
        let shared = b.merge(&core[1..w]);
        let k = (w * w - 1) / 2;
        // Per tile row: its extra values, sorted, then with its own column's.
        let rows: Vec<[Vec<u32>; 2]> = (0..2)
            .map(|e| {
                let singles: Vec<Vec<u32>> = (1..w).map(|c| vec![b.leaf(c, w - 1 + e)]).collect();
                let sorted = b.merge(&singles);
                [0, w].map(|c| {
                    let own = [b.leaf(c, w - 1 + e)];
                    (0..w).map(|j| b.kth(&sorted, &own, j)).collect()
                })
            })
            .collect();
        let mut outs = [0; 4];
        for (tc, c) in [0, w].into_iter().enumerate() {
            // Ranks k − w..=k of the middle rows of this window's columns, then the extra row.
            let column: Vec<u32> = (k - w..=k).map(|j| b.kth(&shared, &core[c], j)).collect();
            for (tr, row) in rows.iter().enumerate() {
                outs[2 * tr + tc] = b.kth(&column, &row[tc], w);
            }
        }
        b.finish(outs.to_vec())
    }

    /// The network as the body of a `macro_rules!` macro named `name`, taking
    /// `($leaf:ident, $min:path, $max:path)`: it expands to a block of straight-line `let`s
    /// (`$leaf!(c, r)` loads rank r of column c, placed just before its first use so that
    /// few values are live at once) whose value is the array of the medians in `out` order. The
    /// compiler then keeps the values in registers, which an interpreted network cannot.
    pub fn rust_macro(&self, name: &str) -> String {
        let mut body = String::new();
        let mut emitted = vec![false; self.values.len()];
        let mut emit_leaf = |body: &mut String, id: u32| {
            if let Value::Leaf { c, r } = self.values[id as usize]
                && !emitted[id as usize]
            {
                emitted[id as usize] = true;
                body.push_str(&format!("        let v{id} = $leaf!({c}, {r});\n"));
            }
        };
        for (id, v) in self.values.iter().enumerate() {
            if let Value::MinMax { max, a, b } = *v {
                emit_leaf(&mut body, a);
                emit_leaf(&mut body, b);
                let op = if max { "$max" } else { "$min" };
                body.push_str(&format!("        let v{id} = {op}(v{a}, v{b});\n"));
            }
        }
        let outs: Vec<String> = self.out.iter().map(|o| format!("v{o}")).collect();
        format!(
            "macro_rules! {name} {{\n    ($leaf:ident, $min:path, $max:path) => {{{{\n{body}        [{}]\n    }}}};\n}}\n",
            outs.join(", ")
        )
    }
}
