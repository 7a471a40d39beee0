"""colmap_irav4.global_mapping against the mapper command on the bundled
example; options errors; Ctrl-C."""

import logging
import os
import signal
import unittest

import numpy as np

import colmap_irav4

from common import (EXAMPLE_DB, MODEL_FILES, TempDirTestCase, command_model,
                    read_bytes, require_binary)

ONE_THREAD = {"Mapper": {"num_threads": 1, "seed": 0}}


class GlobalMappingTest(TempDirTestCase):
    def test_same_model_as_the_command(self):
        """The command's model, byte for byte, with one thread and the same
        seed. The heaps of the command and of a Python process differ: this
        holds because the Ceres solves do not depend on addresses (Ceres
        orders the blocks of an elimination group by address, and they are
        solved as copies in one array, in id order: ParameterBlockCopies)."""
        require_binary(self)
        command_dir = os.path.join(self.tmp, "command")
        command_model(command_dir)
        python_dir = os.path.join(self.tmp, "python")
        models, summary = colmap_irav4.global_mapping(
            EXAMPLE_DB, python_dir, options=ONE_THREAD)
        # Field by field first (a failure says where), then the files.
        command = colmap_irav4.read_model(os.path.join(command_dir, "0"))
        ours = models[0]
        columns = {"cameras": ("camera_id", "model", "width", "height",
                               "params"),
                   "images": ("image_id", "name", "camera_id", "point3D_ids",
                              "rotation", "translation", "points2D"),
                   "points3D": ("point3D_id", "rgb", "track", "xyz", "error")}
        for table, names in columns.items():
            for column in names:
                a, b = command[table][column], ours[table][column]
                self.assertEqual(len(a), len(b), column)
                for x, y in zip(a, b):
                    np.testing.assert_array_equal(x, y, err_msg=column)
        for name in MODEL_FILES:
            self.assertEqual(
                read_bytes(os.path.join(python_dir, "0", name)),
                read_bytes(os.path.join(command_dir, "0", name)), name)
        self.assertEqual(len(models), len(summary["models"]))
        self.assertEqual(summary["models"][0]["num_registered_images"], 11)
        self.assertEqual(len(ours["points3D"]["xyz"]),
                         summary["models"][0]["num_points"])
        # The returned model is the written one.
        written = colmap_irav4.read_model(os.path.join(python_dir, "0"))
        self.assertTrue(
            (written["points3D"]["xyz"] == ours["points3D"]["xyz"]).all())
        self.assertTrue(os.path.isfile(os.path.join(python_dir,
                                                    "summary.json")))

    def test_options_reach_the_pipeline(self):
        models, summary = colmap_irav4.global_mapping(
            EXAMPLE_DB, self.tmp,
            options={"Mapper": {"num_threads": 1,
                                "rotation_method": "l1_irls"},
                     "output_type": "TXT"})
        self.assertEqual(summary["rotation_method"], "l1_irls")
        self.assertTrue(os.path.isfile(os.path.join(self.tmp, "0",
                                                    "images.txt")))
        self.assertEqual(len(models[0]["images"]["name"]), 11)

    def test_progress_goes_to_logging(self):
        with self.assertLogs("colmap_irav4", level="INFO") as logs:
            colmap_irav4.global_mapping(EXAMPLE_DB, self.tmp,
                                        options=ONE_THREAD)
        text = "\n".join(logs.output)
        self.assertIn("view graph", text)
        self.assertIn("Wrote 1 model(s)", text)

    def test_bad_options_name_the_option(self):
        cases = [
            ({"Mapper": {"no_such_option": 1}}, "Mapper.no_such_option"),
            ({"Mapper.num_threads": "two"}, "Mapper.num_threads"),
            ({"Mapper": {"rotation_method": "magic"}},
             "Mapper.rotation_method"),
            ({"RotationAveraging": {"theta_deg": -1.0}},
             "RotationAveraging.theta_deg"),
            ({"Mapper": {"num_threads": [1]}}, "Mapper.num_threads"),
            ({"output_type": "PLY"}, "output_type"),
            ({"help": True}, "help"),
        ]
        for options, name in cases:
            with self.subTest(options=options):
                with self.assertRaisesRegex(ValueError, name):
                    colmap_irav4.global_mapping(EXAMPLE_DB, self.tmp,
                                                options=options)
        self.assertEqual(os.listdir(self.tmp), [])  # nothing written

    def test_bad_paths_name_the_file(self):
        missing = os.path.join(self.tmp, "missing.db")
        with self.assertRaisesRegex(ValueError, "missing.db"):
            colmap_irav4.global_mapping(missing, os.path.join(self.tmp, "o"))
        self.assertFalse(os.path.exists(missing))
        with self.assertRaisesRegex(ValueError, "image_path"):
            colmap_irav4.global_mapping(EXAMPLE_DB, self.tmp, image_path=3)
        with self.assertRaisesRegex(ValueError, "no_images"):
            colmap_irav4.global_mapping(
                EXAMPLE_DB, self.tmp,
                image_path=os.path.join(self.tmp, "no_images"))

    def test_ctrl_c_stops_cleanly_and_keeps_the_old_model(self):
        colmap_irav4.global_mapping(EXAMPLE_DB, self.tmp, options=ONE_THREAD)
        old = {name: read_bytes(os.path.join(self.tmp, "0", name))
               for name in MODEL_FILES + ("../summary.json",)}

        class CtrlCOnFirstStage(logging.Handler):
            """Sends SIGINT to the process when the first stage is logged
            (the run is then under way: rotation averaging comes next)."""
            sent = False

            def emit(self, record):
                if not self.sent and "view graph" in record.getMessage():
                    self.sent = True
                    os.kill(os.getpid(), signal.SIGINT)

        handler = CtrlCOnFirstStage()
        logger = logging.getLogger("colmap_irav4")
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        try:
            with self.assertRaises(KeyboardInterrupt):
                colmap_irav4.global_mapping(
                    EXAMPLE_DB, self.tmp,
                    options={"Mapper": {"num_threads": 1, "seed": 1}})
        finally:
            logger.removeHandler(handler)
            logger.setLevel(logging.NOTSET)
        self.assertTrue(handler.sent)
        # No partial output: the old model and summary, nothing else.
        self.assertEqual(sorted(os.listdir(self.tmp)), ["0", "summary.json"])
        for name, data in old.items():
            self.assertEqual(read_bytes(os.path.join(self.tmp, "0", name)),
                             data, name)
        # The interrupt does not stick to the next run.
        models, _ = colmap_irav4.global_mapping(EXAMPLE_DB, self.tmp,
                                                options=ONE_THREAD)
        self.assertEqual(len(models[0]["images"]["name"]), 11)


if __name__ == "__main__":
    unittest.main()
