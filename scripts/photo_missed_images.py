#!/usr/bin/env python3
"""The connected images of a generated photo collection (scene_generator
--layout photo) that a mapper run did not register, with their true and
false pairs (the database's inlier counts), and the true-pair components at
several inlier thresholds against the registered images.

  photo_missed_images.py --scene SCENE_DIR --models OUTPUT_DIR

Per missed image: PARTNER:INLIERS/COVISIBLE(cCONFIG), with "-" after a
partner that is not registered either.
"""
import argparse
import os
import sqlite3
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from evaluate_photo_models import model_images, read_scene  # noqa: E402

PAIR_ID_FACTOR = 2147483647


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", required=True)
    parser.add_argument("--models", required=True)
    parser.add_argument("--thresholds", default="1,30,50")
    args = parser.parse_args()
    parts, priors, connected = read_scene(args.scene)
    db = sqlite3.connect("file:%s?mode=ro" %
                         os.path.join(args.scene, "database.db"), uri=True)
    names = dict(db.execute("SELECT image_id, name FROM images"))
    geometries = {}
    for pair_id, rows, config in db.execute(
            "SELECT pair_id, rows, config FROM two_view_geometries"):
        id2 = pair_id % PAIR_ID_FACTOR
        geometries[((pair_id - id2) // PAIR_ID_FACTOR, id2)] = (rows, config)
    db.close()
    kinds = {}
    with open(os.path.join(args.scene, "pairs.txt")) as f:
        for line in f:
            id1, id2, kind, covisible = line.split()
            kinds[(int(id1), int(id2))] = (kind, int(covisible))
    registered = {}
    for model in sorted(os.listdir(args.models)):
        path = os.path.join(args.models, model)
        if os.path.isfile(os.path.join(path, "images.bin")):
            for name in model_images(path):
                registered[name] = model
    ids = {name: image_id for image_id, name in names.items()}
    for name in sorted(connected - set(registered),
                       key=lambda n: (len(n), n)):
        image_id = ids[name]
        true_pairs, false_pairs = [], []
        for (id1, id2), (kind, covisible) in sorted(kinds.items()):
            if image_id not in (id1, id2):
                continue
            other = id2 if id1 == image_id else id1
            rows, config = geometries.get((id1, id2), (0, 0))
            text = "%d:%d/%d(c%d)%s" % (other, rows, covisible, config,
                                        "" if names[other] in registered
                                        else "-")
            (true_pairs if kind == "true" else false_pairs).append(text)
        print("%s part %d prior %d true %s | false %s" % (
            name, parts[name], priors[name], " ".join(true_pairs),
            " ".join(false_pairs)))
    for threshold in (int(t) for t in args.thresholds.split(",")):
        parent = {}

        def find(x):
            while parent.setdefault(x, x) != x:
                x = parent[x]
            return x

        for (id1, id2), (kind, _) in kinds.items():
            if kind == "true" and \
                    geometries.get((id1, id2), (0, 0))[0] >= threshold:
                parent[find(id1)] = find(id2)
        components = {}
        for image_id in list(parent):
            components.setdefault(find(image_id), []).append(names[image_id])
        sizes = sorted(components.values(), key=len, reverse=True)
        print("inliers >= %d: %d of %d images registered, %d components: %s"
              % (threshold,
                 sum(1 for c in sizes for n in c if n in registered),
                 sum(len(c) for c in sizes), len(sizes),
                 " ".join("%d(part %d, %d registered, models %s)" % (
                     len(c), parts[c[0]],
                     sum(1 for n in c if n in registered),
                     ",".join(sorted({registered[n] for n in c
                                      if n in registered})) or "-")
                          for c in sizes)))


if __name__ == "__main__":
    main()
