"""read_model / write_model round trips (byte for byte), their checks, and
compare_models / align_models against model_comparer."""

import copy
import os
import re
import tempfile
import unittest

import numpy as np

import colmap_irav4

import common
from common import (MODEL_FILES, TempDirTestCase, command_model, read_bytes,
                    require_binary, run_command)


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


class ModelsTest(TempDirTestCase):
    @classmethod
    def setUpClass(cls):
        require_binary(cls)
        cls._model_dir = tempfile.TemporaryDirectory(prefix="colmap_irav4_py_")
        cls.model_path = command_model(cls._model_dir.name)

    @classmethod
    def tearDownClass(cls):
        cls._model_dir.cleanup()

    def setUp(self):
        super().setUp()
        self.model = colmap_irav4.read_model(self.model_path)

    def test_columns(self):
        images = self.model["images"]
        n = len(images["image_id"])
        self.assertEqual(n, 11)
        self.assertEqual(images["rotation"].shape, (n, 3, 3))
        self.assertEqual(images["quaternion"].shape, (n, 4))
        self.assertEqual(images["translation"].shape, (n, 3))
        for r in images["rotation"]:
            np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        points = self.model["points3D"]
        self.assertEqual(points["rgb"].dtype, np.uint8)
        # Tracks and observations agree.
        index = {int(i): k for k, i in enumerate(images["image_id"])}
        for point_id, track in zip(points["point3D_id"][:50],
                                   points["track"][:50]):
            for image_id, idx in track:
                self.assertEqual(
                    images["point3D_ids"][index[int(image_id)]][idx],
                    point_id)

    def test_round_trip_byte_for_byte(self):
        for fmt in ("BIN", "TXT"):
            with self.subTest(format=fmt):
                out = os.path.join(self.tmp, fmt)
                colmap_irav4.write_model(self.model, out, format=fmt)
                back = colmap_irav4.read_model(out)
                for table in ("cameras", "images", "points3D"):
                    for column, value in self.model[table].items():
                        if isinstance(value, list):
                            for a, b in zip(value, back[table][column]):
                                np.testing.assert_array_equal(a, b)
                        else:
                            np.testing.assert_array_equal(
                                value, back[table][column])
        for name in MODEL_FILES:
            self.assertEqual(read_bytes(os.path.join(self.model_path, name)),
                             read_bytes(os.path.join(self.tmp, "BIN", name)))
        # The text model is what the command's converter writes.
        run_command("model_converter", "--input_path", self.model_path,
                    "--output_path", os.path.join(self.tmp, "converted"),
                    "--output_type", "TXT")
        for name in ("cameras.txt", "images.txt", "points3D.txt"):
            self.assertEqual(
                read_bytes(os.path.join(self.tmp, "converted", name)),
                read_bytes(os.path.join(self.tmp, "TXT", name)))

    def test_rotation_without_quaternion(self):
        model = copy.deepcopy(self.model)
        del model["images"]["quaternion"]
        out = os.path.join(self.tmp, "rotation_only")
        colmap_irav4.write_model(model, out)
        back = colmap_irav4.read_model(out)
        np.testing.assert_allclose(back["images"]["rotation"],
                                   self.model["images"]["rotation"],
                                   atol=1e-12)

    def test_bad_models_name_the_column(self):
        def changed(table, column, change):
            model = copy.deepcopy(self.model)
            model[table][column] = change(model[table][column])
            return model

        def not_rotation(r):
            r = r.copy()
            r[2] *= 2
            return r

        def wrong_track(tracks):
            tracks = list(tracks)
            tracks[0] = tracks[0].copy()
            tracks[0][0, 1] += 1
            return tracks

        def nan_quaternion(q):
            q = q.copy()
            q[1] = np.nan
            return q

        cases = [
            (changed("images", "rotation", not_rotation),
             r"model\['images'\]\['rotation'\]\[2\]"),
            (changed("images", "translation", lambda t: t[:, :2]),
             r"model\['images'\]\['translation'\]"),
            (changed("images", "camera_id", lambda c: c.astype(float)),
             r"model\['images'\]\['camera_id'\]"),
            (changed("images", "name", lambda n: n[:-1]),
             r"model\['images'\]\['name'\]"),
            (changed("cameras", "model", lambda m: ["FISHEYE9"] * len(m)),
             r"model\['cameras'\]\['model'\]\[0\]"),
            (changed("cameras", "params", lambda p: [x[:2] for x in p]),
             "parameters"),
            (changed("points3D", "rgb", lambda c: c.astype(int) + 300),
             r"model\['points3D'\]\['rgb'\]"),
            (changed("points3D", "track", wrong_track), "point3D"),
            (changed("images", "camera_id", lambda c: c + 1000),
             "references camera"),
            ({"cameras": {}}, r"model\['cameras'\]\['camera_id'\]"),
            ("not a model", "model"),
        ]
        model = copy.deepcopy(self.model)
        del model["images"]["rotation"]
        model["images"]["quaternion"] = nan_quaternion(
            model["images"]["quaternion"])
        cases.append((model, "invalid rotation quaternion"))
        for index, (model, pattern) in enumerate(cases):
            with self.subTest(case=index, pattern=pattern):
                out = os.path.join(self.tmp, "bad%d" % index)
                with self.assertRaisesRegex(ValueError, pattern):
                    colmap_irav4.write_model(model, out)
                self.assertFalse(os.path.exists(out))
        with self.assertRaisesRegex(ValueError, "format"):
            colmap_irav4.write_model(self.model, self.tmp, format="PLY")
        with self.assertRaisesRegex(ValueError, "missing_model"):
            colmap_irav4.read_model(os.path.join(self.tmp, "missing_model"))

    def test_compare_models_prints_what_model_comparer_prints(self):
        other = os.path.join(self.tmp, "other")
        colmap_irav4.global_mapping(
            common.EXAMPLE_DB, other,
            options={"Mapper": {"rotation_method": "l1_irls"}})
        other = os.path.join(other, "0")
        printed = run_command("model_comparer", "--input_path1",
                              self.model_path, "--input_path2",
                              other).stdout
        result = colmap_irav4.compare_models(self.model_path, other)
        self.assertTrue(result["aligned"])
        self.assertEqual(result["num_common"], 11)
        median = float(re.search(r"rotation error \[deg\]: median (\S+),",
                                 printed).group(1))
        # Printed with 4 and 6 decimals.
        self.assertAlmostEqual(result["rotation_error_median_deg"], median,
                               delta=0.51e-4)
        centre = float(re.search(r"centre error: median (\S+),",
                                 printed).group(1))
        self.assertAlmostEqual(result["center_error_median"], centre,
                               delta=0.51e-6)
        self.assertGreater(result["rotation_error_median_deg"], 0)
        self.assertEqual(result["model"]["num_registered_images"], 11)
        # Bad input.
        with self.assertRaisesRegex(ValueError, "reference/gt_path"):
            colmap_irav4.compare_models(self.model)
        with self.assertRaisesRegex(ValueError, "Comparer.max_relative_error"):
            colmap_irav4.compare_models(
                self.model, self.model,
                options={"Comparer": {"max_relative_error": 2.0}})

    def test_align_models_recovers_a_similarity(self):
        moved = copy.deepcopy(self.model)
        scale, rotation = 2.5, rotation_z(0.7)
        translation = np.array([1.0, -2.0, 3.0])
        # x' = s R x + t: points move, cam_from_world becomes
        # R_i R^T and t_i' = s t_i - R_i R^T t.
        moved["points3D"]["xyz"] = (
            scale * self.model["points3D"]["xyz"] @ rotation.T + translation)
        images = moved["images"]
        images["rotation"] = self.model["images"]["rotation"] @ rotation.T
        images["translation"] = np.array([
            scale * t - r @ translation
            for r, t in zip(images["rotation"],
                            self.model["images"]["translation"])])
        del images["quaternion"]
        result = colmap_irav4.align_models(moved, self.model)
        self.assertTrue(result["aligned"])
        self.assertAlmostEqual(result["scale"], 1 / scale, places=9)
        np.testing.assert_allclose(result["rotation"], rotation.T, atol=1e-9)
        self.assertLess(result["rotation_error_max_deg"], 1e-6)
        aligned = result["aligned_model"]
        np.testing.assert_allclose(aligned["points3D"]["xyz"],
                                   self.model["points3D"]["xyz"], atol=1e-8)
        np.testing.assert_allclose(aligned["images"]["rotation"],
                                   self.model["images"]["rotation"],
                                   atol=1e-9)


if __name__ == "__main__":
    unittest.main()
