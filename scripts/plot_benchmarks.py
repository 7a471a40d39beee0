#!/usr/bin/env python3
"""Plots of a scripts/benchmark.sh run (Debian's python3-matplotlib).

  scripts/plot_benchmarks.py --results DIR/results.csv [MORE.csv ...] --out DIR
      [--rotation_table rotation_benchmark_output.txt ...]

Writes DIR/comparison.csv (one row per scene: ours beside COLMAP 3.8's
incremental mapper and COLMAP 4's global_mapper, with the time and memory
ratios theirs / ours), DIR/accuracy_summary.csv (per scene family, e.g. the
seeds of one size, and mapper: the mean and median of our error over theirs
and how often ours is lower), DIR/results.json, DIR/time_vs_images.png (wall and CPU time against the number of
images on log-log axes, per mapper, with the growth exponents fitted by least
squares on the synthetic scenes), DIR/errors.png (median camera-centre and rotation
errors per scene and mapper) and, given tables printed by
tools/rotation_benchmark, DIR/rotation_protocols.png (median rotation error
against the outlier percentage, per method and noise level).
"""

import argparse
import csv
import json
import math
import os
import re
import sys

try:
    import matplotlib

    matplotlib.use("Agg")  # no display
    import matplotlib.pyplot as plt
except ImportError:  # tables only
    plt = None

LABELS = {
    "colmap_irav4": "colmap_irav4 mapper",
    "colmap38_incremental": "COLMAP 3.8 incremental",
    "colmap4_global_mapper": "COLMAP 4 global_mapper",
}
COLORS = {
    "colmap_irav4": "tab:red",
    "colmap38_incremental": "tab:blue",
    "colmap4_global_mapper": "tab:green",
}


def as_float(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def write_comparison(rows, out_dir):
    """comparison.csv and results.json; returns the comparison rows."""
    json.dump(rows, open(os.path.join(out_dir, "results.json"), "w"), indent=1)
    scenes = []
    for row in rows:
        if row["scene"] not in scenes:
            scenes.append(row["scene"])

    def get(scene, mapper):
        return next((r for r in rows if r["scene"] == scene and r["mapper"] == mapper), {})

    def ratio(a, b):
        try:
            return "%.2f" % (float(a) / float(b))
        except (TypeError, ValueError, ZeroDivisionError):
            return ""

    names = [("ours", "colmap_irav4"), ("colmap", "colmap38_incremental"),
             ("global", "colmap4_global_mapper")]
    fields = ["scene", "num_images"]
    for m, _ in names:
        fields += [m + "_status", m + "_seconds", m + "_cpu_seconds", m + "_peak_mib", m + "_registered",
                   m + "_rotation_median_deg", m + "_center_median_mm", m + "_center_max_mm"]
    fields += ["colmap_time_ratio", "colmap_cpu_ratio", "colmap_memory_ratio",
               "global_time_ratio", "global_cpu_ratio", "global_memory_ratio"]
    table = []
    for scene in scenes:
        ours = get(scene, "colmap_irav4")
        out = {"scene": scene, "num_images": ours.get("num_images", "")}
        for m, name in names:
            r = get(scene, name)
            out[m + "_status"] = r.get("status", "not_run")
            for column in ["seconds", "cpu_seconds", "peak_mib", "registered", "rotation_median_deg",
                           "center_median_mm", "center_max_mm"]:
                out[m + "_" + column] = r.get(column, "")
        for m, name in names[1:]:
            r = get(scene, name)
            ok = r.get("status") == "ok" and ours.get("status") == "ok"
            out[m + "_time_ratio"] = ratio(r.get("seconds"), ours.get("seconds")) if ok else ""
            out[m + "_cpu_ratio"] = (ratio(r.get("cpu_seconds"), ours.get("cpu_seconds"))
                                     if ok else "")
            out[m + "_memory_ratio"] = ratio(r.get("peak_mib"), ours.get("peak_mib")) if ok else ""
        table.append(out)
    with open(os.path.join(out_dir, "comparison.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(table)
    return table


def scene_family(row):
    """The scenes compared together: the seeds of one synthetic size (the
    name without its _sN suffix), or all Strecha scenes."""
    if row["kind"] == "strecha":
        return "strecha"
    return re.sub(r"_s[0-9]+$", "", row["scene"])


def write_accuracy_summary(rows, out_dir):
    """accuracy_summary.csv: per scene family and competitor, our median
    errors over theirs (below 1: ours closer), mean, median and count of
    scenes where ours is lower, over the scenes where both registered the
    same number of images (the others are counted as skipped); returns the
    rows."""
    def errors(row):
        try:
            return float(row["center_median_mm"]), float(row["rotation_median_deg"])
        except (KeyError, TypeError, ValueError):
            return None

    ours = {r["scene"]: r for r in rows if r["mapper"] == "colmap_irav4" and r["status"] == "ok"}
    groups = {}
    skipped = {}
    for r in rows:
        if r["mapper"] == "colmap_irav4" or r["status"] != "ok" or r["scene"] not in ours:
            continue
        key = (scene_family(r), r["mapper"])
        groups.setdefault(key, [])
        skipped.setdefault(key, 0)
        a, b = errors(ours[r["scene"]]), errors(r)
        if (a is None or b is None or b[0] <= 0 or b[1] <= 0 or
                r["registered"] != ours[r["scene"]]["registered"]):
            skipped[key] += 1
            continue
        groups[key].append((a[0] / b[0], a[1] / b[1]))

    def median(values):
        values = sorted(values)
        mid = len(values) // 2
        return values[mid] if len(values) % 2 else 0.5 * (values[mid - 1] + values[mid])

    fields = ["family", "mapper", "scenes", "scenes_skipped",
              "center_ratio_mean", "center_ratio_median", "center_ours_lower",
              "rotation_ratio_mean", "rotation_ratio_median", "rotation_ours_lower"]
    table = []
    for (family, mapper), ratios in groups.items():
        if not ratios:
            table.append({"family": family, "mapper": mapper, "scenes": 0,
                          "scenes_skipped": skipped[(family, mapper)]})
            continue
        centres = [c for c, _ in ratios]
        rotations = [r for _, r in ratios]
        table.append({
            "family": family, "mapper": mapper, "scenes": len(ratios),
            "scenes_skipped": skipped[(family, mapper)],
            "center_ratio_mean": "%.3f" % (sum(centres) / len(centres)),
            "center_ratio_median": "%.3f" % median(centres),
            "center_ours_lower": sum(c < 1 for c in centres),
            "rotation_ratio_mean": "%.3f" % (sum(rotations) / len(rotations)),
            "rotation_ratio_median": "%.3f" % median(rotations),
            "rotation_ours_lower": sum(r < 1 for r in rotations),
        })
    with open(os.path.join(out_dir, "accuracy_summary.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(table)
    return table


def growth_exponent(points):
    """Least-squares slope of log(seconds) against log(images)."""
    if len(points) < 2:
        return None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    if sxx == 0:
        return None
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx


def plot_time(rows, path):
    """Wall time (solid) and CPU time (dashed; robust to a loaded machine)."""
    fig, ax = plt.subplots(figsize=(6.5, 4.5), dpi=80)
    exponents = {}
    for mapper in LABELS:
        for column, style, what in [("seconds", "o-", "wall"), ("cpu_seconds", "s--", "CPU")]:
            points = sorted(
                (int(r["num_images"]), float(r[column]))
                for r in rows
                if r["mapper"] == mapper and r["kind"] == "synthetic" and r["status"] == "ok"
                and as_float(r.get(column)))
            if not points:
                continue
            k = growth_exponent(points)
            exponents[mapper + " " + what] = k
            label = "%s, %s%s" % (LABELS[mapper], what,
                                  "" if k is None else " (~ n^%.2f)" % k)
            ax.loglog([p[0] for p in points], [p[1] for p in points], style,
                      color=COLORS[mapper], label=label, alpha=1.0 if what == "wall" else 0.6)
            for n, t in points:
                ax.annotate("%.0f s" % t, (n, t), textcoords="offset points",
                            xytext=(4, -10), fontsize=7, color=COLORS[mapper])
    ax.set_xlabel("images (synthetic scenes)")
    ax.set_ylabel("time [s]")
    ax.set_title("Mapping time against scene size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return exponents


def plot_errors(rows, path):
    scenes = []
    for r in rows:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    mappers = [m for m in LABELS if any(r["mapper"] == m for r in rows)]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=80)
    width = 0.8 / max(1, len(mappers))
    for panel, (column, title) in enumerate(
            [("center_median_mm", "median camera-centre error [mm]"),
             ("rotation_median_deg", "median rotation error [deg]")]):
        ax = axes[panel]
        for k, mapper in enumerate(mappers):
            values = []
            for scene in scenes:
                row = next((r for r in rows if r["scene"] == scene and r["mapper"] == mapper), None)
                value = as_float(row[column]) if row and row["status"] == "ok" else None
                values.append(value)
            xs = [i + (k - (len(mappers) - 1) / 2) * width for i in range(len(scenes))]
            ax.bar([x for x, v in zip(xs, values) if v is not None],
                   [v for v in values if v is not None], width,
                   color=COLORS[mapper], label=LABELS[mapper])
            # Missing bars (not run, failed) are listed in comparison.csv.
        ax.set_xticks(range(len(scenes)))
        ax.set_xticklabels(scenes, rotation=30, ha="right", fontsize=8)
        ax.set_title(title + " (log scale)", fontsize=10)
        ax.set_yscale("log")  # a failed scene would hide the others
        ax.grid(True, axis="y", which="both", alpha=0.3)
        if panel == 0:
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def read_rotation_tables(paths):
    """Rows of tools/rotation_benchmark's table: graph sigma p% | median / mean tail time mem."""
    data = []  # (graph, sigma, percent, method, median)
    for path in paths:
        methods = None
        for line in open(path):
            if line.startswith("#") or not line.strip():
                continue
            parts = [p.strip() for p in line.split("|")]
            if parts[0].split()[0] == "graph":
                methods = parts[1:]
                continue
            if methods is None:
                continue
            head = parts[0].split()
            if len(head) < 3:
                continue
            graph, sigma, percent = head[0], float(head[1]), float(head[2])
            for method, cell in zip(methods, parts[1:]):
                match = re.match(r"\s*([0-9.eE+-]+|nan)\s*/", cell)
                if match:
                    data.append((graph, sigma, percent, method, float(match.group(1))))
    return data


def plot_rotation(data, path):
    settings = sorted({(g, s) for g, s, _, _, _ in data})
    fig, axes = plt.subplots(1, len(settings), figsize=(4.5 * len(settings), 4), dpi=80,
                             squeeze=False)
    for ax, (graph, sigma) in zip(axes[0], settings):
        methods = []
        for g, s, _, m, _ in data:
            if (g, s) == (graph, sigma) and m not in methods:
                methods.append(m)
        styles = ["-", "--", ":", "-."]
        for k, method in enumerate(methods):
            points = sorted((p, e) for g, s, p, m, e in data
                            if (g, s, m) == (graph, sigma, method))
            # Distinct line styles: methods that agree draw on top of each other.
            ax.plot([p for p, _ in points], [e for _, e in points],
                    marker="o", linestyle=styles[k % len(styles)], label=method)
        ax.set_yscale("log")
        ax.set_xlabel("outlier edges [%]")
        ax.set_ylabel("median rotation error [deg]")
        ax.set_title("%s graph, noise %g deg" % (graph, sigma), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", nargs="*", default=[],
                        help="results.csv of scripts/benchmark.sh (several are merged)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--rotation_table", nargs="*", default=[],
                        help="saved output of tools/rotation_benchmark")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    if args.results:
        for path in args.results:
            if not os.path.exists(path):
                sys.exit("ERROR: %s: no such file" % path)
        rows = []
        for path in args.results:
            rows += list(csv.DictReader(open(path)))
        table = write_comparison(rows, args.out)
        print("%-16s %6s %9s %9s %6s %9s %9s %11s %11s" % (
            "scene", "images", "ours [s]", "COLMAP", "ratio", "ours MiB", "COLMAP",
            "ours mm", "COLMAP mm"))
        for r in table:
            print("%-16s %6s %9s %9s %6s %9s %9s %11s %11s" % (
                r["scene"], r["num_images"], r["ours_seconds"] or r["ours_status"],
                r["colmap_seconds"] or r["colmap_status"], r["colmap_time_ratio"],
                r["ours_peak_mib"], r["colmap_peak_mib"], r["ours_center_median_mm"],
                r["colmap_center_median_mm"]))
        summary = write_accuracy_summary(rows, args.out)
        if summary:
            print("errors, ours / theirs (mean, median over the scenes; scenes where ours is lower):")
        for r in summary:
            skipped = (" (%d skipped: registered images differ)" % r["scenes_skipped"]
                       if r["scenes_skipped"] else "")
            if not r["scenes"]:
                print("  %-28s vs %-22s no scene to compare%s" % (r["family"], r["mapper"], skipped))
                continue
            print("  %-28s vs %-22s %2d scenes%s: centre %s, %s (%d lower); rotation %s, %s (%d lower)" % (
                r["family"], r["mapper"], r["scenes"], skipped, r["center_ratio_mean"],
                r["center_ratio_median"], r["center_ours_lower"], r["rotation_ratio_mean"],
                r["rotation_ratio_median"], r["rotation_ours_lower"]))
        if plt is None:
            print("matplotlib missing (apt-get install python3-matplotlib): no plots")
            return
        exponents = plot_time(rows, os.path.join(args.out, "time_vs_images.png"))
        plot_errors(rows, os.path.join(args.out, "errors.png"))
        for mapper, k in exponents.items():
            if k is not None:
                print("growth exponent %s: %.2f" % (mapper, k))
    if args.rotation_table:
        if plt is None:
            sys.exit("ERROR: matplotlib missing (apt-get install python3-matplotlib)")
        data = read_rotation_tables(args.rotation_table)
        if not data:
            sys.exit("ERROR: no rotation_benchmark rows in %s" % ", ".join(args.rotation_table))
        plot_rotation(data, os.path.join(args.out, "rotation_protocols.png"))
    print("plots in %s" % args.out)


if __name__ == "__main__":
    main()
