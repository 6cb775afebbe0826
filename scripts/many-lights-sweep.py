#!/usr/bin/env python3
"""The many-light sweep (docs/many-lights.md): a scene's lights replaced by an N x N grid
of lamps for each N, rendered by every method side by side, timed as medians of
interleaved runs (Embree for every method, the render phase of `lightmesh render
--stats`), with and without each lamp's range.

  scripts/many-lights-sweep.py --lightmesh build/apps/lightmesh --scene scenes/real/parque.json \\
      --box -6 -6 6 6 --height 4.5 --total 120 --range 5 --lights 16,64,256,1024 \\
      --size 320x240 --repeat 3 [--methods none,rt,soft,lmm,lmm:reduced] [--markdown out.md]

Lamps: an n x n grid (N = n^2) over the box [X0, X1] x [Z0, Z1] at height Y, each of
intensity TOTAL / N. Prints a Markdown table per culling setting: the render phase of each
method, the shadow part (method - none) over RT's, rays per pixel (RT: shadow rays; the
light mesh: its nodes' segments plus its shadow rays and local-visibility segments; soft:
its shadow rays), the light mesh's node storage and each method's peak memory; then the
crossover N* where a method's render time drops below RT's (log-linear between the N
measured; "-" if it never does, "< N0" if it already does at the first).
Wrap it in `flock /tmp/lightmesh-bench.lock` on a shared machine.
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def number(text):
    return float(text.replace(",", ""))


def run(binary, scene, method, size, extra):
    w, h = size.split("x")
    out = os.path.join(tempfile.gettempdir(), "lm-sweep-%d.exr" % os.getpid())
    shadows, _, variant = method.partition(":")  # "lmm:reduced": a light-mesh variant
    cmd = [binary, "render", scene, "--shadows", shadows, "--width", w, "--height", h, "--stats", "-q", "-o", out] + extra
    if variant:
        cmd += ["--variant", variant]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    s = r.stdout
    f = {"render": number(re.search(r"render ([\d.]+) s", s.split("time", 1)[1]).group(1))}
    f["shadow"] = number(re.search(r"shadow ([\d,]+)", s.split("rays", 1)[1]).group(1))
    m = re.search(r"peak ([\d.]+) (\w+)", s)
    f["peak"] = m.group(1) + " " + m.group(2) if m else "?"
    m = re.search(r"local-visibility segments ([\d,]+)", s)
    f["local"] = number(m.group(1)) if m else 0
    m = re.search(r"node segments ([\d,]+)", s)
    f["nodeSegments"] = number(m.group(1)) if m else 0
    m = re.search(r"node storage ([\d.]+ \w+)( at most)?", s)
    f["storage"] = m.group(1) if m else ""
    m = re.search(r"\((\d+) bytes? per node", s) or re.search(r"\((\d+) byte\(s\) per node", s)
    f["bytesPerNode"] = m.group(1) if m else ""
    m = re.search(r"; ([\d.]+ \w+) touched", s)
    f["touched"] = m.group(1) if m else ""
    return f


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--lightmesh", required=True)
    p.add_argument("--scene", required=True)
    p.add_argument("--box", nargs=4, type=float, required=True)
    p.add_argument("--height", type=float, required=True)
    p.add_argument("--total", type=float, required=True)
    p.add_argument("--range", type=float, required=True)
    p.add_argument("--radius", type=float)
    p.add_argument("--lights", default="16,64,256,1024")
    p.add_argument("--size", default="320x240")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--methods", default="none,rt,soft,lmm")
    p.add_argument("--culling", default="both", help="off, on, or both (off then on; also written off,on)")
    p.add_argument("--markdown")
    a = p.parse_args()
    methods = a.methods.split(",")
    counts = [int(x) for x in a.lights.split(",")]
    tmp = tempfile.mkdtemp(prefix="lm-sweep-")
    w, h = (int(v) for v in a.size.split("x"))
    pixels = w * h
    lines = ["Scene %s, %s, lamps in a grid over [%g, %g] x [%g, %g] at y = %g, total intensity %g; "
             "render phase, medians of %d interleaved runs, Embree." % (os.path.basename(a.scene), a.size, a.box[0], a.box[2],
                                                                      a.box[1], a.box[3], a.height, a.total, a.repeat)]
    cullings = ["off", "on"] if a.culling == "both" else a.culling.split(",")
    if any(c not in ("off", "on") for c in cullings):
        sys.exit("many-lights-sweep.py: --culling %s: off, on or both" % a.culling)
    for culling in cullings:
        rows = []
        for n in counts:
            side = int(round(math.sqrt(n)))
            scene = os.path.join(tmp, "lamps-%d-%s.json" % (n, culling))
            cmd = [sys.executable, os.path.join(HERE, "many-lights.py"), a.scene, scene, "--grid", str(side), str(n // side),
                   "--box"] + [str(v) for v in a.box] + ["--height", str(a.height), "--intensity", str(a.total / n)]
            if culling == "on":
                cmd += ["--range", str(a.range)]
            if a.radius is not None:
                cmd += ["--radius", str(a.radius)]
            subprocess.run(cmd, check=True, capture_output=True)
            runs = {m: [] for m in methods}
            for rep in range(a.repeat + 1):  # a warm-up round first
                for m in methods:
                    f = run(a.lightmesh, scene, m, a.size, [])
                    if rep:
                        runs[m].append(f)
            med = {m: statistics.median(f["render"] for f in runs[m]) for m in methods}
            last = {m: runs[m][-1] for m in methods}
            rows.append((n, med, last))
            print("N %d culling %s: %s" % (n, culling, ", ".join("%s %.3f s" % (m, med[m]) for m in methods)), file=sys.stderr)
        lines.append("")
        lines.append("Culling %s%s:" % (culling, " (range %g)" % a.range if culling == "on" else ""))
        lines.append("")
        head = "| lights | " + " | ".join("%s s" % m for m in methods)
        others = [m for m in methods if m not in ("none", "rt")]
        head += "".join(" | %s / RT | %s shadow part / RT's" % (m, m) for m in others)
        head += " | RT rays/pixel" + "".join(" | %s rays/pixel" % m for m in others)
        head += " | lmm node storage (touched) | peak memory " + "/".join(methods) + " |"
        lines.append(head)
        lines.append("|" + "---|" * (head.count("|") - 1))
        for n, med, last in rows:
            rt = med.get("rt")
            none = med.get("none", 0)
            cells = ["%d" % n] + ["%.3f" % med[m] for m in methods]
            for m in others:
                cells.append("%.2f" % (med[m] / rt))
                cells.append("%.2f" % ((med[m] - none) / (rt - none)) if rt - none > 0 else "-")
            cells.append("%.1f" % (last["rt"]["shadow"] / pixels))
            for m in others:
                f = last[m]
                cells.append("%.1f" % ((f["shadow"] + f["local"] + f["nodeSegments"]) / pixels))
            lm = next((last[m] for m in methods if m.startswith("lmm")), None)
            cells.append("%s (%s B/node; %s)" % (lm["storage"], lm["bytesPerNode"], lm["touched"] or "-") if lm else "-")
            cells.append(" / ".join(last[m]["peak"] for m in methods))
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
        for m in others:
            ratio = [(n, med[m] / med["rt"]) for n, med, _ in rows]
            star = "-"
            if ratio[0][1] < 1:
                star = "< %d" % ratio[0][0]
            else:
                for (n0, r0), (n1, r1) in zip(ratio, ratio[1:]):
                    if r0 >= 1 > r1:
                        t = (math.log(r0)) / (math.log(r0) - math.log(r1))
                        star = "%.0f" % math.exp(math.log(n0) + t * (math.log(n1) - math.log(n0)))
                        break
            lines.append("Crossover N* (%s overtakes RT, culling %s): %s" % (m, culling, star))
    text = "\n".join(lines) + "\n"
    print(text)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
