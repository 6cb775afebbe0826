#!/usr/bin/env python3
"""A light-radius sweep, as a researcher would write it with the lightmesh module.

For each light radius, renders a scene with the default soft shadows, hard shadows (rt) and
area sampling at a few ray counts, judges each against an area-light reference of many rays
(PSNR, lightmesh.compare) and plots PSNR against render time with matplotlib.

    PYTHONPATH=build/python python3 examples/radius_sweep.py --scene builtin:gazebo \\
        --size 480x360 --radii 0.05,0.1,0.2,0.4 -o radius-sweep.png

Times are wall-clock seconds of lightmesh.render (load and set-up included), on whatever
else the machine is doing: run it on a quiet machine for figures worth plotting.
"""
import argparse
import time

import lightmesh


def timed_render(scene, **options):
    start = time.perf_counter()
    image = lightmesh.render(scene, **options)
    return image, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="builtin:gazebo")
    parser.add_argument("--size", default="480x360", help="WIDTHxHEIGHT")
    parser.add_argument("--radii", default="0.05,0.1,0.2,0.4", help="light radii, comma-separated")
    parser.add_argument("--area-samples", default="1,4,16", help="area rays per light, comma-separated")
    parser.add_argument("--ref-samples", type=int, default=256, help="the reference's rays per light")
    parser.add_argument("-o", "--output", default="radius-sweep.png")
    args = parser.parse_args()

    import matplotlib
    import matplotlib.ticker
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    width, height = (int(v) for v in args.size.lower().split("x"))
    radii = [float(r) for r in args.radii.split(",")]
    samples = [int(n) for n in args.area_samples.split(",")]
    base = dict(width=width, height=height)

    fig, axes = plt.subplots(1, len(radii), figsize=(4 * len(radii), 3.6), squeeze=False)
    for ax, radius in zip(axes[0], radii):
        options = dict(base, light_radius=radius)
        reference, _ = timed_render(args.scene, shadows="area", samples=args.ref_samples, **options)
        points = {}
        # (rt ignores the radius: lights are points to it.)
        for label, method in [("default (soft)", dict(options, shadows="soft")), ("rt", dict(base, shadows="rt"))]:
            image, seconds = timed_render(args.scene, **method)
            points[label] = [(seconds, lightmesh.compare(reference, image)["psnr"])]
        points["area"] = []
        for n in samples:
            image, seconds = timed_render(args.scene, shadows="area", samples=n, **options)
            points["area"].append((seconds, lightmesh.compare(reference, image)["psnr"]))
        for label, pts in points.items():
            ax.plot([t for t, _ in pts], [p for _, p in pts], "o-" if len(pts) > 1 else "o", label=label)
            print(f"radius {radius:g}: {label}: " + ", ".join(f"{t:.3f} s {p:.2f} dB" for t, p in pts))
        ax.set_title(f"light radius {radius:g}")
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.tick_params(axis="x", which="minor", labelsize=7)
        ax.set_xlabel("render time (s)")
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel(f"PSNR against area N={args.ref_samples} (dB)")
    axes[0][0].legend()
    fig.suptitle(f"{args.scene}, {width}x{height}")
    fig.tight_layout()
    fig.savefig(args.output, dpi=100)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
