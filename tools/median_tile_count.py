#!/usr/bin/env python3
"""Counts the min/max operations of 7x7 median networks, to judge a change of the mask's median
before writing it in Rust (BENCHMARKS.md, "Mask", sixth pass).

    python3 tools/median_tile_count.py

Builds, symbolically and pruned to what the outputs use, the same way src/mask/median_net.rs does:
- "pair": the network in use: two horizontally adjacent medians, the six shared presorted columns
  merged by Batcher's merge phases, each median selected from that list and its own column by the
  order-statistic identity k-th(A u B) = min over i + j = k + 1 of max(A[i-1], B[j-1]);
- "tile": a 2x2 tile of medians (after Adams 2021, separable sorting networks): the 6x6 core all
  four share merged once, each tile column's own 6 values and each tile row's 6 + 1 extra values
  joined by the identity.
The tile network is checked against sorting on random 8x8 blocks (ties included). Plain Python,
no packages.
"""
import random

WIRES, GROUP = 64, 8
SORT6 = [(0, 5), (1, 3), (2, 4), (1, 2), (3, 4), (0, 3), (2, 5), (0, 1), (2, 3), (4, 5), (1, 2), (3, 4)]


def batcher_merge_phases():
    """Batcher's odd-even merge sort comparators on WIRES wires, merge phases from GROUP up."""
    cmp, p = [], GROUP
    while p < WIRES:
        k = p
        while k >= 1:
            j = k % p
            while j + k < WIRES:
                for i in range(min(k, WIRES - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        cmp.append((i + j, i + j + k))
                j += 2 * k
            k //= 2
        p *= 2
    return cmp


class Net:
    def __init__(self):
        self.nodes = []

    def push(self, node):
        self.nodes.append(node)
        return len(self.nodes) - 1

    def leaf(self, *key):
        return self.push(("leaf",) + key)

    def op(self, kind, a, b):
        return self.push((kind, a, b))

    def merge(self, groups):
        """Sorted union of up to 8 sorted groups of at most 8 values (missing values are +inf)."""
        wires = [g[r] if r < len(g) else None for g in groups + [[]] * (WIRES // GROUP - len(groups))
                 for r in range(GROUP)]
        for i, j in batcher_merge_phases():
            a, b = wires[i], wires[j]
            if b is None:
                continue
            if a is None:
                wires[i], wires[j] = b, a
                continue
            wires[i], wires[j] = self.op("min", a, b), self.op("max", a, b)
        return wires[:sum(len(g) for g in groups)]

    def kth(self, a, b, k):
        """Value of rank k (0-based) of the union of sorted lists a and b."""
        acc = None
        for j in range(len(b) + 1):
            i = k + 1 - j
            if not 0 <= i <= len(a):
                continue
            term = a[i - 1] if j == 0 else b[j - 1] if i == 0 else self.op("max", a[i - 1], b[j - 1])
            acc = term if acc is None else self.op("min", acc, term)
        return acc

    def sort(self, values, network):
        v = list(values)
        for a, b in network:
            v[a], v[b] = self.op("min", v[a], v[b]), self.op("max", v[a], v[b])
        return v

    def live_ops(self, outs):
        """Min/max operations the outputs depend on."""
        live = [False] * len(self.nodes)
        for o in outs:
            live[o] = True
        for i in range(len(self.nodes) - 1, -1, -1):
            if live[i] and self.nodes[i][0] != "leaf":
                live[self.nodes[i][1]] = live[self.nodes[i][2]] = True
        return sum(1 for i, n in enumerate(self.nodes) if live[i] and n[0] != "leaf")

    def evaluate(self, leaf_value):
        val = []
        for n in self.nodes:
            val.append(leaf_value(n) if n[0] == "leaf" else (min if n[0] == "min" else max)(val[n[1]], val[n[2]]))
        return val


def pair():
    """The network in use: columns 0..7 of 7 presorted values, medians of columns 0..6 and 1..7."""
    net = Net()
    cols = [[net.leaf("col", c, r) for r in range(7)] for c in range(8)]
    shared = net.merge(cols[1:7])
    return net, [net.kth(shared, cols[0], 24), net.kth(shared, cols[7], 24)]


def tile():
    """2x2 medians over an 8x8 block: rows 1..6 of each column presorted ("core"), rows 0 and 7 apart."""
    net = Net()
    core = [[net.leaf("core", c, r) for r in range(6)] for c in range(8)]
    extra = [[net.leaf("extra", c, r) for c in range(8)] for r in range(2)]
    shared = net.merge(core[1:7])
    rows = {}
    for r in range(2):
        e = net.sort([extra[r][c] for c in range(1, 7)], SORT6)
        for c in range(2):
            rows[r, c] = [net.kth(e, [extra[r][7 * c]], k) for k in range(7)]
    outs = []
    for c in range(2):
        column = {k: net.kth(shared, core[7 * c], k) for k in range(17, 25)}
        for r in range(2):
            acc = None
            for j in range(8):
                term = column[24] if j == 0 else net.op("max", column[24 - j], rows[r, c][j - 1])
                acc = term if acc is None else net.op("min", acc, term)
            outs.append(((r, c), acc))
    return net, outs


def check_tile(net, outs, trials=300):
    rng = random.Random(1)
    for _ in range(trials):
        img = [[rng.choice([rng.random(), float(rng.randint(0, 3))]) for _ in range(8)] for _ in range(8)]
        core = [sorted(img[r][c] for r in range(1, 7)) for c in range(8)]

        val = net.evaluate(lambda n: core[n[2]][n[3]] if n[1] == "core" else img[7 * n[3]][n[2]])
        for (r, c), o in outs:
            window = sorted(img[y][x] for y in range(r, r + 7) for x in range(c, c + 7))
            assert val[o] == window[24], (r, c)


def main():
    net, outs = pair()
    ops = net.live_ops(outs)
    # Per output row, every column's 7 values are sorted by 21 compare-exchanges (42 min/max).
    print(f"pair: {ops} min/max per 2 pixels = {ops / 2:.1f} per pixel, + 42 column sort = {ops / 2 + 42:.1f}")
    net, outs = tile()
    check_tile(net, outs)
    ops = net.live_ops([o for _, o in outs])
    # Columns of 6 shared by the two output rows: 12 compare-exchanges per column per 2 rows.
    print(f"tile 2x2: {ops} min/max per 4 pixels = {ops / 4:.1f} per pixel, + 12 column sort = "
          f"{ops / 4 + 12:.1f} (checked against sorting)")


if __name__ == "__main__":
    main()
