#!/usr/bin/env python3
"""How a model's points split the true points of a generated scene
(scene_generator): for each true 3D point whose observations the model
holds, over how many of the model's points they are spread, and whether
the split points come from one track of the database's matches (split by
triangulation) or from several (split by the track builder).

  track_splits.py --scene SCENE_DIR --model MODEL_DIR [--tracks]
      [--max_duplicate_distance 4]

SCENE_DIR holds database.db and gt/ (a COLMAP model whose images' keypoints
are the database's, linked to the true points). MODEL_DIR is one model
(images.bin, points3D.bin). --tracks also rebuilds the tracks from the
database's inlier matches of every pair (union-find, components with two
keypoints of one image farther apart than --max_duplicate_distance px
dropped, as colmap_irav4's track builder does; the mapper's own tracks use
only the pairs the rotation filter keeps).
"""
import argparse
import collections
import os
import sqlite3
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from evaluate_photo_models import read_images_bin  # noqa: E402


def read_images(path):
    """image_id -> (name, [point3D_id per keypoint]) of images.bin."""
    return read_images_bin(path, with_point_ids=True)


def read_points(path):
    """point3D_id -> [(image_id, point2D_idx)] of points3D.bin."""
    points = {}
    with open(path, "rb") as f:
        (num,) = struct.unpack("<Q", f.read(8))
        for _ in range(num):
            point_id, = struct.unpack("<Q", f.read(8))
            f.read(8 * 3 + 3 + 8)  # xyz, rgb, error
            (length,) = struct.unpack("<Q", f.read(8))
            data = f.read(8 * length)
            points[point_id] = [struct.unpack_from("<II", data, 8 * k)
                                for k in range(length)]
    return points


def database_tracks(database, max_duplicate_distance):
    """(name, idx) -> track number, for the tracks the builder keeps; and
    the number of components dropped as inconsistent."""
    db = sqlite3.connect("file:%s?mode=ro" % database, uri=True)
    names = dict(db.execute("SELECT image_id, name FROM images"))
    xy = {}
    for image_id, rows, cols, data in db.execute(
            "SELECT image_id, rows, cols, data FROM keypoints"):
        xy[image_id] = [struct.unpack_from("<ff", data, 4 * cols * k)
                        for k in range(rows)]
    parent = {}

    def find(a):
        root = a
        while parent.get(root, root) != root:
            root = parent[root]
        while parent.get(a, a) != root:
            parent[a], a = root, parent[a]
        return root

    for pair_id, rows, data in db.execute(
            "SELECT pair_id, rows, data FROM two_view_geometries "
            "WHERE rows > 0"):
        image_id2 = pair_id % 2147483647
        image_id1 = (pair_id - image_id2) // 2147483647
        for k in range(rows):
            a, b = struct.unpack_from("<II", data, 8 * k)
            ra, rb = find((image_id1, a)), find((image_id2, b))
            if ra != rb:
                parent[ra] = rb
    db.close()
    components = collections.defaultdict(list)
    for node in list(parent):
        components[find(node)].append(node)
    track_of = {}
    num_inconsistent = 0
    for number, (root, nodes) in enumerate(components.items()):
        by_image = collections.defaultdict(list)
        for image_id, idx in nodes:
            by_image[image_id].append(xy[image_id][idx])
        consistent = all(
            (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 <=
            max_duplicate_distance ** 2
            for pts in by_image.values() for p in pts for q in pts)
        if not consistent:
            num_inconsistent += 1
            for image_id, idx in nodes:
                track_of[(names[image_id], idx)] = -1 - number
            continue
        for image_id, idx in nodes:
            track_of[(names[image_id], idx)] = number
    return track_of, num_inconsistent


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", required=True)
    parser.add_argument("--model", required=True)
    parser.add_argument("--tracks", action="store_true")
    parser.add_argument("--max_duplicate_distance", type=float, default=4.0)
    args = parser.parse_args()

    gt_images = read_images(os.path.join(args.scene, "gt", "images.bin"))
    gt_point = {}  # (name, idx) -> true point id
    for name, ids in gt_images.values():
        for idx, point_id in enumerate(ids):
            if point_id >= 0:
                gt_point[(name, idx)] = point_id
    images = read_images(os.path.join(args.model, "images.bin"))
    points = read_points(os.path.join(args.model, "points3D.bin"))
    names = {image_id: name for image_id, (name, _) in images.items()}

    num_obs = sum(len(t) for t in points.values())
    # Model points per true point; impure model points (observations of
    # several true points or of clutter).
    spread = collections.defaultdict(set)
    obs_of_true = collections.Counter()
    num_impure = 0
    num_clutter_obs = 0
    for point_id, track in points.items():
        truths = collections.Counter()
        for image_id, idx in track:
            truth = gt_point.get((names[image_id], idx))
            if truth is None:
                num_clutter_obs += 1
                continue
            truths[truth] += 1
        if len(truths) > 1 or (truths and sum(truths.values()) < len(track)):
            num_impure += 1
        if truths:
            # The majority true point is the one the model point stands for.
            truth = truths.most_common(1)[0][0]
            spread[truth].add(point_id)
            obs_of_true[truth] += len(track)
    num_true = len(spread)
    split = {t: s for t, s in spread.items() if len(s) > 1}
    hist = collections.Counter(min(len(s), 5) for s in spread.values())
    print("model: %d points, %d observations, mean track length %.3f"
          % (len(points), num_obs, num_obs / max(len(points), 1)))
    print("true points represented: %d (observations / true points %.3f)"
          % (num_true, num_obs / max(num_true, 1)))
    print("model points per true point: " + ", ".join(
        "%s: %d" % ("5+" if k == 5 else k, hist[k]) for k in sorted(hist)))
    print("true points split over >= 2 model points: %d (%.1f%%), holding "
          "%d model points and %d observations" % (
              len(split), 100.0 * len(split) / max(num_true, 1),
              sum(len(s) for s in split.values()),
              sum(obs_of_true[t] for t in split)))
    print("impure model points (several true points or clutter): %d; "
          "clutter observations %d" % (num_impure, num_clutter_obs))
    # Model points of split true points by observation count.
    lengths = collections.Counter(
        min(len(points[p]), 6) for s in split.values() for p in s)
    print("lengths of the points of split true points: " + ", ".join(
        "%s: %d" % ("6+" if k == 6 else k, lengths[k])
        for k in sorted(lengths)))
    # The observations the model lacks: of each represented true point,
    # those in registered images that no model point holds.
    registered = set(names.values())
    held = set((names[i], idx) for t in points.values() for i, idx in t)
    gt_points = collections.defaultdict(list)
    for key, truth in gt_point.items():
        gt_points[truth].append(key)
    missing = sum(1 for t in spread for key in gt_points[t]
                  if key[0] in registered and key not in held)
    print("observations of represented true points in registered images "
          "not in the model: %d" % missing)

    if args.tracks:
        track_of, num_inconsistent = database_tracks(
            os.path.join(args.scene, "database.db"),
            args.max_duplicate_distance)
        # Split true points: are their model points of one track?
        same_track = 0
        several_tracks = 0
        for truth, ids in split.items():
            tracks = set()
            for p in ids:
                for image_id, idx in points[p]:
                    tracks.add(track_of.get((names[image_id], idx)))
            if len(tracks) == 1:
                same_track += 1
            else:
                several_tracks += 1
        print("database tracks: %d components dropped as inconsistent"
              % num_inconsistent)
        print("split true points whose model points are of one track: %d, "
              "of several tracks: %d" % (same_track, several_tracks))
        # True points (of the represented ones) whose keypoints in the
        # registered images fall in several tracks or dropped components.
        split_tracks = 0
        dropped_obs = 0
        for truth in spread:
            tracks = set()
            for key in gt_points[truth]:
                if key[0] not in registered:
                    continue
                track = track_of.get(key)
                if track is None:
                    continue
                if track < 0:
                    dropped_obs += 1
                    continue
                tracks.add(track)
            if len(tracks) > 1:
                split_tracks += 1
        print("represented true points whose matched keypoints fall in "
              "several kept tracks: %d; their keypoints in dropped "
              "(inconsistent) components: %d" % (split_tracks, dropped_obs))
        # The missing observations: keypoints never matched, in dropped
        # components, or in a kept track the model uses elsewhere / not.
        model_tracks = set(track_of.get(key) for key in held)
        unmatched = dropped = used_track = unused_track = 0
        for t in spread:
            for key in gt_points[t]:
                if key[0] not in registered or key in held:
                    continue
                track = track_of.get(key)
                if track is None:
                    unmatched += 1
                elif track < 0:
                    dropped += 1
                elif track in model_tracks:
                    used_track += 1
                else:
                    unused_track += 1
        print("missing observations: never matched %d, in dropped components "
              "%d, in a track with model points %d, in a track without %d"
              % (unmatched, dropped, used_track, unused_track))
    return 0


if __name__ == "__main__":
    sys.exit(main())
