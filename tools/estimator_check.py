"""Usage: tools/.venv/bin/python tools/estimator_check.py SCENE pt|bpt|ibpt|mmlt SHORT_S LONG_S [OUTDIR]

Which reference-free error estimate predicts the LDR MSE at a later time?
For a method, render two independent halves (seeds 1, 2) of k passes (or t seconds) each,
and, as the 'final', seeds 3..6 at the long setting. Compare:
  lin:  linearised variance (slope at 3x3-smoothed level)   -> predicted MSE of the 2k average
  emp:  mean (ldr(a)-ldr(b))^2 / 4                            -> same
  true: MSE of the 2k average vs the reference
and then the true MSE at the long setting vs each estimate scaled by time ratio.
"""
import sys, subprocess, json, numpy as np, OpenImageIO as oiio, os
from linearise import box, slope
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target/release")
def read(p):
    i = oiio.ImageInput.open(p); s = i.spec(); px = i.read_image(format="float")
    names = list(s.channelnames); i.close()
    attrs = {a.name: a.value for a in s.extra_attribs}
    rgb = np.stack([px[..., names.index(c)] for c in "RGB"], -1)
    return rgb.astype(np.float64), attrs
def ldr(x): return 255 * np.clip(np.nan_to_num(x), 0, 1) ** (1 / 2.2)
def smooth(x): return box(x, 3)
def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
scene, kind, short, long_ = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
ref, _ = read(os.path.join(ROOT, f"fixtures/references/{scene}.exr"))
out = os.path.join(sys.argv[5] if len(sys.argv) > 5 else "/tmp/estimator_check", f"{scene}-{kind}")
os.makedirs(out, exist_ok=True)
def render(seed, budget, tag):
    p = f"{out}/{tag}-{seed}.exr"
    if not os.path.exists(p):
        if kind == "mmlt":
            run([f"{BIN}/mixmc-mmlt", os.path.join(ROOT, f"fixtures/scenes/{scene}.json"), "--include-direct", "--time", budget, "--seed", str(seed), "-o", p, "-q"])
        else:
            run([f"{BIN}/mixmc-omc", os.path.join(ROOT, f"fixtures/scenes/{scene}.json"), "--method", kind, "--time", budget, "--seed", str(seed), "-o", p, "-q"])
    return read(p)
(a, aa), (b, ba) = render(1, short, "s"), render(2, short, "s")
t_short = aa["mixmc.seconds"] + ba["mixmc.seconds"]
avg = (a + b) / 2
lin = np.mean(slope(smooth(avg)) ** 2 * (a - b) ** 2 / 4)
emp = np.mean((ldr(a) - ldr(b)) ** 2) / 4
true_short = np.mean((ldr(avg) - ldr(ref)) ** 2)
finals = [render(s, long_, "l") for s in (3, 4)]
t_long = np.mean([f[1]["mixmc.seconds"] for f in finals])
true_long = np.mean([np.mean((ldr(f[0]) - ldr(ref)) ** 2) for f in finals])
ratio = t_short / t_long
print(json.dumps(dict(scene=scene, kind=kind, t_short=round(t_short, 2), t_long=round(t_long, 2),
    true_short=round(true_short, 2), lin=round(lin, 2), emp=round(emp, 2),
    true_long=round(true_long, 2), lin_pred=round(lin * ratio, 2), emp_pred=round(emp * ratio, 2))))
lev = smooth(avg)
for k in (1, 3, 5, 9):
    var = box((a - b) ** 2 / 4, k) if k > 1 else (a - b) ** 2 / 4  # variance of the 2-half average
    cap = ldr(lev) ** 2
    for tag, t in (("short", t_short), ("long", t_long)):
        e = np.minimum(slope(lev) ** 2 * var * (t_short / t), np.maximum(cap, 0))
        print(f"  capped k={k} {tag}: {np.mean(e):.1f}")
