//! The symbolic median network behind [`super::median`], shared with `build.rs`, which turns it
//! into straight-line code (a macro per window size), and with the tests, which check its size.
//! It uses nothing outside this file, so the build script can include it as a module.
//!
//! The network computes two horizontally adjacent w×w medians at once, over the w + 1 window
//! columns `0..=w`, each column presorted ascending (rank 0 = smallest):
//! 1. the w − 1 columns both windows share are merged once, as the presorted groups of
//!    Batcher's odd-even merge sort on 64 wires (groups of 8, the missing values +∞), so only
//!    its merge phases remain; comparators touching +∞ are dropped;
//! 2. each median is then selected from that merged list A and its own column B by the
//!    order-statistic identity `k-th of A ∪ B = min_{i+j=k+1} max(A[i−1], B[j−1])` (an empty
//!    prefix counts as −∞): every split of the first k + 1 values bounds the k-th from above,
//!    and the split the merged order makes attains it;
//! 3. only the min/max operations the two medians depend on are kept: 184 per pixel for w = 7
//!    (80 for w = 5), where one window at a time needs 372 (152).

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
/// the left and the right median.
#[derive(Clone, Debug)]
pub struct Network {
    pub values: Vec<Value>,
    pub out: [u32; 2],
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

impl Network {
    /// The network for a `w`×`w` window (odd, 3..=7).
    pub fn new(w: usize) -> Network {
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
        // Keep only what the medians depend on, renumbered in the same order.
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
            out: outs.map(|o| index[o as usize]),
        }
    }

    /// The network as the body of a `macro_rules!` macro named `name`, taking
    /// `($leaf:ident, $min:path, $max:path)`: it expands to a block of straight-line `let`s
    /// (`$leaf!(c, r)` loads rank r of column c, placed just before its first use so that
    /// few values are live at once) whose value is `[left median, right median]`. The
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
        format!(
            "macro_rules! {name} {{\n    ($leaf:ident, $min:path, $max:path) => {{{{\n{body}        [v{}, v{}]\n    }}}};\n}}\n",
            self.out[0], self.out[1]
        )
    }
}
