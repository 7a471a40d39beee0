#!/usr/bin/env python3
"""Models of a generated photo collection (scene_generator --layout photo)
against its truth: registered images (those a true pair connects, and those
none does: false registrations), models against the landmarks (parts), and
rotation, centre and focal errors, each model aligned on its own, and the
images whose rotation is over 5 deg off (a folded landmark puts up to half
its images there, near 180 deg, while the medians stay small).

  evaluate_photo_models.py --scene SCENE_DIR --models OUTPUT_DIR
      [--binary build/colmap_irav4] [--label NAME]

SCENE_DIR holds database.db, gt/, pairs.txt and image_parts.txt;
OUTPUT_DIR the mapper's models (0/, 1/, ...). Prints one CSV row (header
with --header) and the per-model lines to stderr.
"""
import argparse
import os
import sqlite3
import statistics
import subprocess
import sys

COLUMNS = ("label,images,connected_images,parts,models,registered,"
           "registered_connected,registered_unconnected,models_mixing_parts,"
           "parts_split,largest_model_share_min,rotation_median_deg,"
           "center_median_m,focal_median,focal_median_prior,"
           "focal_median_no_prior,rotation_over_5deg")

# Over this rotation error an image is wrong, not inaccurate: at its mirror
# twin's place (a fold) or otherwise misplaced.
WRONG_ROTATION_DEG = 5


def read_scene(scene):
    parts = {}
    with open(os.path.join(scene, "image_parts.txt")) as f:
        for line in f:
            name, part = line.split()
            parts[name] = int(part)
    names = {}
    priors = {}
    db = sqlite3.connect("file:%s?mode=ro" % os.path.join(scene, "database.db"),
                         uri=True)
    camera_prior = dict(db.execute(
        "SELECT camera_id, prior_focal_length FROM cameras"))
    for image_id, name, camera_id in db.execute(
            "SELECT image_id, name, camera_id FROM images"):
        names[image_id] = name
        priors[name] = bool(camera_prior[camera_id])
    db.close()
    connected = set()
    with open(os.path.join(scene, "pairs.txt")) as f:
        for line in f:
            id1, id2, kind, _ = line.split()
            if kind == "true":
                connected.add(names[int(id1)])
                connected.add(names[int(id2)])
    return parts, priors, connected


def compare(binary, model, gt):
    """Per image (name -> (rotation deg, centre, focal)) from model_comparer
    --per_image; empty if it cannot align the model (fewer than 3 images:
    they count as registered, without errors)."""
    result = subprocess.run(
        [binary, "model_comparer", "--input_path1", model, "--input_path2", gt,
         "--per_image", "1"], capture_output=True, text=True)
    errors = {}
    in_list = False
    for line in result.stdout.splitlines():
        if line.startswith("per image"):
            in_list = True
            continue
        if in_list and line.startswith("  "):
            fields = line.split()
            errors[fields[0]] = (float(fields[2]), float(fields[3]),
                                 float(fields[4]))
    return errors


def read_images_bin(path, with_point_ids=False):
    """image_id -> (name, [point3D_id per keypoint] or None) of a COLMAP
    images.bin, in the file's order."""
    import struct
    images = {}
    with open(path, "rb") as f:
        (num_images,) = struct.unpack("<Q", f.read(8))
        for _ in range(num_images):
            (image_id,) = struct.unpack("<I", f.read(4))
            f.read(8 * 7 + 4)  # qvec, tvec, camera_id
            name = b""
            while True:
                c = f.read(1)
                if c == b"\0":
                    break
                name += c
            (num_points,) = struct.unpack("<Q", f.read(8))
            data = f.read(num_points * 24)
            ids = None
            if with_point_ids:
                ids = [struct.unpack_from("<q", data, 24 * k + 16)[0]
                       for k in range(num_points)]
            images[image_id] = (name.decode(), ids)
    return images


def model_images(model):
    """Image names of a COLMAP binary model (images.bin)."""
    return [name for name, _ in
            read_images_bin(os.path.join(model, "images.bin")).values()]


def median(values):
    return statistics.median(values) if values else float("nan")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", required=True)
    parser.add_argument("--models", required=True)
    parser.add_argument("--binary", default="build/colmap_irav4")
    parser.add_argument("--label", default="")
    parser.add_argument("--header", action="store_true")
    args = parser.parse_args()
    parts, priors, connected = read_scene(args.scene)
    gt = os.path.join(args.scene, "gt")
    num_parts = len({parts[name] for name in connected})
    per_part = {}
    for name in connected:
        per_part[parts[name]] = per_part.get(parts[name], 0) + 1
    models = sorted(d for d in os.listdir(args.models)
                    if os.path.isfile(os.path.join(args.models, d, "images.bin")))
    registered = set()
    mixing = 0
    models_of_part = {}
    largest = {}
    rotations, centres, focals, focal_prior, focal_no_prior = [], [], [], [], []
    for model in models:
        path = os.path.join(args.models, model)
        images = model_images(path)
        registered.update(images)
        model_parts = {}
        for name in images:
            if name in connected:
                model_parts[parts[name]] = model_parts.get(parts[name], 0) + 1
        if len(model_parts) > 1:
            mixing += 1
        for part, count in model_parts.items():
            models_of_part[part] = models_of_part.get(part, 0) + 1
            largest[part] = max(largest.get(part, 0), count)
        errors = compare(args.binary, path, gt)
        for name, (rotation, centre, focal) in errors.items():
            if name not in connected:
                continue
            rotations.append(rotation)
            centres.append(centre)
            focals.append(focal)
            (focal_prior if priors[name] else focal_no_prior).append(focal)
        sys.stderr.write("  model %s: %d images (parts %s), rotation median "
                         "%.4f deg, over %g deg %d, focal median %.4f\n" % (
                             model, len(images), model_parts,
                             median([e[0] for e in errors.values()]),
                             WRONG_ROTATION_DEG,
                             sum(1 for e in errors.values()
                                 if e[0] > WRONG_ROTATION_DEG),
                             median([e[2] for e in errors.values()])))
    share = min((largest.get(part, 0) / count
                 for part, count in per_part.items()), default=0)
    row = [args.label, len(parts), len(connected), num_parts, len(models),
           len(registered), len(registered & connected),
           len(registered - connected), mixing,
           sum(1 for n in models_of_part.values() if n > 1),
           "%.3f" % share, "%.4f" % median(rotations),
           "%.4f" % median(centres), "%.4f" % median(focals),
           "%.4f" % median(focal_prior), "%.4f" % median(focal_no_prior),
           sum(1 for r in rotations if r > WRONG_ROTATION_DEG)]
    if args.header:
        print(COLUMNS)
    print(",".join(str(value) for value in row))


if __name__ == "__main__":
    main()
