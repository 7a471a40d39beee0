#!/usr/bin/env python3
"""colmap_irav4 from Python: maps the bundled example (Strecha's fountain,
tests/data/fountain-P11.db), prints the run's summary, then averages the
rotations of its view graph with two methods and compares them with each
other and with the mapped model.

    PYTHONPATH=build/python /usr/bin/python3 examples/map_and_average.py [OUT]

(OUT: output directory, default /tmp/colmap_irav4_python_example.)
"""

import logging
import os
import sys

import numpy as np

import colmap_irav4

HERE = os.path.dirname(os.path.abspath(__file__))
DATABASE = os.path.join(HERE, "..", "tests", "data", "fountain-P11.db")


def angle_deg(a, b):
    """Angle of the rotation between a and b (degrees)."""
    return np.degrees(np.arccos(np.clip((np.trace(a @ b.T) - 1) / 2, -1, 1)))


def errors_deg(estimate, reference):
    """Per-image angles between two sets of cam_from_world rotations after
    the global rotation G (R_i -> R_i G) that best maps one onto the other:
    rotation averaging fixes the rotations up to such a G."""
    m = sum(r.T @ e for e, r in zip(estimate, reference))
    u, _, vt = np.linalg.svd(m)
    g = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    return np.array([angle_deg(e, r @ g) for e, r in zip(estimate, reference)])


def main():
    output = sys.argv[1] if len(sys.argv) > 1 else \
        "/tmp/colmap_irav4_python_example"
    # The mapper's stages, as the command logs them.
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")

    models, summary = colmap_irav4.global_mapping(
        DATABASE, output, options={"Mapper": {"num_threads": 2}})
    model = models[0]
    figures = summary["models"][0]
    print(f"\nMapped {figures['num_registered_images']} images, "
          f"{figures['num_points']} points, mean reprojection error "
          f"{figures['mean_reprojection_error_per_point']:.3f} px per point, "
          f"in {summary['total_seconds']:.2f} s; model in {output}/0")

    graph = colmap_irav4.view_graph(DATABASE)
    names = graph["image_names"]
    print(f"View graph: {len(names)} images, {len(graph['pairs'])} pairs")
    results = {}
    for method in ("irav4", "spanning_tree"):
        rotations, ra_summary = colmap_irav4.rotation_averaging(
            len(names), graph["pairs"], graph["relative_rotations"],
            weights=graph["weights"], method=method)
        results[method] = rotations
        print(f"  {method}: {ra_summary['num_cameras_estimated']} of "
              f"{len(names)} rotations in {ra_summary['seconds']:.4f} s"
              + (f", reference of {ra_summary['reference_size']} images"
                 if method == "irav4" else ""))

    # Images both methods estimated (the others are NaN).
    both = [k for k in range(len(names))
            if not np.isnan(results["irav4"][k]).any()
            and not np.isnan(results["spanning_tree"][k]).any()]
    between = errors_deg(results["irav4"][both], results["spanning_tree"][both])
    print(f"irav4 against spanning_tree ({len(both)} images): median "
          f"{np.median(between):.4f} deg, max {between.max():.4f} deg")
    # The mapped model's rotations (after bundle adjustment), by name.
    index = {name: k for k, name in enumerate(model["images"]["name"])}
    for method, rotations in results.items():
        common = [k for k, name in enumerate(names)
                  if name in index and not np.isnan(rotations[k]).any()]
        mapped = model["images"]["rotation"][[index[names[k]]
                                              for k in common]]
        errors = errors_deg(rotations[common], mapped)
        print(f"{method} against the mapped model ({len(common)} images): "
              f"median {np.median(errors):.3f} deg, max {errors.max():.3f} deg")

if __name__ == "__main__":
    main()
