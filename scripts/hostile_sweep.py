#!/usr/bin/env python3
"""Hostile sweep (issue 28): runs the program on abusive inputs, as a new user
might, and prints one Markdown table row per case: exit code, the first
ERROR (else the first warning) line, and what is on disk afterwards (the
input database unchanged or not, the output's kind and state).

  scripts/hostile_sweep.py BINARY DATABASE [--only PREFIX] [--skip N] > table.md

DATABASE is copied into a scratch directory per case (never written).
Special files are scratch named pipes and, as root, device nodes made in the
scratch directory; no real /dev entry is ever an output here (the /dev/fd/1
case cannot create or replace anything: /proc refuses new names).
"""
import hashlib
import os
import shutil
import sqlite3
import stat
import struct
import subprocess
import sys
import tempfile
import threading

BINARY, DATABASE = sys.argv[1], sys.argv[2]
ONLY = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv else ""
# Resume after the first SKIP cases.
SKIP = int(sys.argv[sys.argv.index("--skip") + 1]) if "--skip" in sys.argv \
    else 0
TIMEOUT = 60


def sha(path):
    try:
        with open(path, "rb") as f:
            return hashlib.sha1(f.read()).hexdigest()
    except OSError:
        return None


def kind(path):
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return "absent"
    if stat.S_ISLNK(mode):
        return "link"
    if stat.S_ISFIFO(mode):
        return "pipe"
    if stat.S_ISCHR(mode):
        return "char device"
    if stat.S_ISDIR(mode):
        return "dir"
    if stat.S_ISSOCK(mode):
        return "socket"
    return "file"


def model_state(path):
    """absent / empty dir / model (N images) / no model: files."""
    if not os.path.lexists(path):
        return "absent"
    if not os.path.isdir(path):
        return kind(path)
    names = sorted(n for n in os.listdir(path))
    if not names:
        return "empty dir"
    if all(os.path.exists(os.path.join(path, n)) for n in
           ("cameras.bin", "images.bin", "points3D.bin")):
        with open(os.path.join(path, "images.bin"), "rb") as f:
            head = f.read(8)
        if len(head) < 8:
            return "model-named files (images.bin of %d bytes)" % len(head)
        count = struct.unpack("<Q", head)[0]
        extra = [n for n in names if not n.endswith(".bin")]
        return "model (%d images)%s" % (count, (" + " + ",".join(extra))
                                         if extra else "")
    if os.path.exists(os.path.join(path, "cameras.txt")):
        return "txt model" + (" + " + ",".join(
            n for n in names if not n.endswith(".txt")) if len(names) > 3
            else "")
    return "no model: " + ",".join(names)[:60]


def out_state(scratch):
    """The state of everything the case could have written."""
    parts = []
    for name in sorted(os.listdir(scratch)):
        if name in ("db.db", "run.log", "hash"):
            continue
        path = os.path.join(scratch, name)
        if name.startswith("out"):
            if os.path.isdir(path) and not os.path.islink(path):
                sub = sorted(os.listdir(path))
                temp = [n for n in sub if ".colmap_irav4_tmp." in n]
                models = [n for n in sub if n.isdigit()]
                summary_dir = "summary.json" in sub and not os.path.isfile(
                    os.path.join(path, "summary.json"))
                desc = ",".join("%s=%s" % (m, model_state(
                    os.path.join(path, m))) for m in models)
                if summary_dir:
                    desc += " +summary.json/ (a directory)"
                elif "summary.json" in sub:
                    with open(os.path.join(path, "summary.json"), "rb") as f:
                        head = f.read(16)
                    desc += " +summary" + (" (the SQLite input)"
                                           if head.startswith(b"SQLite")
                                           else "")
                others = [n for n in sub if not n.isdigit() and
                          n != "summary.json" and n not in temp]
                if others:
                    desc += " +" + ",".join(others)
                if temp:
                    desc += " TEMP LEFT"
                parts.append("%s/: %s" % (name, desc or "empty"))
            else:
                parts.append("%s: %s" % (name, kind(path)))
        elif ".colmap_irav4_tmp." in name:
            parts.append("TEMP LEFT " + name)
        elif kind(path) in ("pipe", "char device", "link", "socket") or \
                name in ("fifo", "fulldev", "nulldev", "fifo.png"):
            parts.append("%s: %s" % (name, kind(path)))
        elif name.startswith("user") or name.startswith("in"):
            parts.append("%s: %s" % (name, kind(path)))
    return "; ".join(parts) or "nothing written"


def first_line(output, exit_code):
    lines = output.splitlines()
    for line in lines:
        if line.startswith("ERROR"):
            return line
    for line in lines:
        if line.startswith("W") and "] " in line:
            return "WARNING " + line.split("] ", 1)[1]
    if exit_code not in (0, 1, 3):
        return (lines[-1] if lines else "(no output)")
    return "-"


CASES = []


def case(name, args, setup=None, stdin=None, shell_suffix=""):
    CASES.append((name, args, setup, stdin, shell_suffix))


def sql(statements):
    def setup(d):
        con = sqlite3.connect(os.path.join(d, "db.db"))
        con.executescript(statements)
        con.commit()
        con.close()
    return setup


def mapper(extra=""):
    return "mapper --database_path db.db --output_path out " + \
        "--Mapper.num_threads 2 " + extra


# ---------------------------------------------------------------------------
# The cases (items 1-14).
case("1 view_graph --output_path DB",
     "view_graph --database_path db.db --output_path db.db")
case("1 rotation_averager --output_path DB",
     "rotation_averager --database_path db.db --output_path db.db")
case("1 rotation_averager --summary_path DB",
     "rotation_averager --database_path db.db --summary_path db.db")
case("1 mapper --database_path OUT/summary.json",
     "mapper --database_path out/summary.json --output_path out",
     lambda d: (os.makedirs(d + "/out"),
                shutil.copy(d + "/db.db", d + "/out/summary.json")))
case("2 view_graph --output_path a named pipe (no reader: reader thread)",
     "view_graph --database_path db.db --output_path fifo",
     lambda d: os.mkfifo(d + "/fifo"))
case("2 rotation_averager --summary_path a named pipe",
     "rotation_averager --database_path db.db --summary_path fifo",
     lambda d: os.mkfifo(d + "/fifo"))
case("2 view_graph --output_path a char device node (1,7 = full)",
     "view_graph --database_path db.db --output_path fulldev",
     lambda d: os.mknod(d + "/fulldev", 0o600 | stat.S_IFCHR,
                        os.makedev(1, 7)))
case("2 rotation_averager --output_path a char device node (1,3 = null)",
     "rotation_averager --database_path db.db --output_path nulldev",
     lambda d: os.mknod(d + "/nulldev", 0o600 | stat.S_IFCHR,
                        os.makedev(1, 3)))
case("2 view_graph --output_path /dev/fd/1",
     "view_graph --database_path db.db --output_path /dev/fd/1")


def junk_model_file(name):
    def setup(d):
        os.makedirs(d + "/out/0")
        open(d + "/out/0/" + name, "w").write("junk")
        open(d + "/out/0/notes.txt", "w").write("mine")
    return setup


for name in ("cameras.txt", "images.bin", "points3D.txt"):
    case("3 OUT/0/%s junk of the user's" % name, mapper(),
         junk_model_file(name))
case("5 mapper 2>&1 | head -n 2", mapper(), shell_suffix=" 2>&1 | head -n 2")
case("6 missing database", "mapper --database_path nope.db --output_path "
     "out/deep")
case("7 --Normalization.extent inf", mapper("--Normalization.extent inf"))
case("10 duplicate image names",
     mapper(), sql("CREATE TABLE i2 AS SELECT * FROM images; DROP TABLE "
                   "images; ALTER TABLE i2 RENAME TO images; UPDATE images "
                   "SET name = (SELECT name FROM images WHERE image_id = 1) "
                   "WHERE image_id = 2;"))
case("10 NULL image name",
     mapper(), sql("CREATE TABLE i2 AS SELECT * FROM images; DROP TABLE "
                   "images; ALTER TABLE i2 RENAME TO images; UPDATE images "
                   "SET name = NULL WHERE image_id = 2;"))
case("11 --Mapper.max_num_tracks 1", mapper("--Mapper.max_num_tracks 1"))
case("12 NUL byte in a name", mapper(),
     sql("UPDATE images SET name = CAST(X'61006200' AS TEXT) "
         "WHERE image_id = 1;"))
case("13 --image_path with a named pipe named like an image",
     mapper("--image_path imgs"),
     lambda d: (os.makedirs(d + "/imgs"), [os.mkfifo(d + "/imgs/" + r[0])
                for r in sqlite3.connect(d + "/db.db").execute(
                    "SELECT name FROM images LIMIT 1")]))
case("14 camera model stored as text", mapper(),
     sql("UPDATE cameras SET model = 'PINHOLE';"))
case("14 NULL camera_id of an image", mapper(),
     sql("CREATE TABLE i2 AS SELECT * FROM images; DROP TABLE images; "
         "ALTER TABLE i2 RENAME TO images; UPDATE images SET camera_id = "
         "NULL WHERE image_id = 1;"))


def focal(value):
    def setup(d):
        con = sqlite3.connect(d + "/db.db")
        model, blob = con.execute(
            "SELECT model, params FROM cameras LIMIT 1").fetchone()
        params = list(struct.unpack("<%dd" % (len(blob) // 8), blob))
        params[0] = value
        if model == 1:
            params[1] = value
        con.execute("UPDATE cameras SET params = ?",
                    (struct.pack("<%dd" % len(params), *params),))
        con.commit()
    return setup


case("14 focal 1e300", mapper(), focal(1e300))
case("14 focal 1e-300", mapper(), focal(1e-300))
case("14 dangling symlink as OUT", mapper(),
     lambda d: os.symlink(d + "/nowhere/x", d + "/out"))
case("14 image name with a newline, TXT", mapper("--output_type TXT"),
     sql("UPDATE images SET name = 'a' || char(10) || 'b' WHERE "
         "image_id = 1;"))

# ---------------------------------------------------------------------------
# Beyond the issue: output paths.
case("out: view_graph via a symlink to the DB",
     "view_graph --database_path db.db --output_path in_link",
     lambda d: os.symlink("db.db", d + "/in_link"))
case("out: view_graph to a hard link of the DB",
     "view_graph --database_path db.db --output_path in_hard",
     lambda d: os.link(d + "/db.db", d + "/in_hard"))
case("out: view_graph to ./sub/../db.db",
     "view_graph --database_path db.db --output_path ./sub/../db.db",
     lambda d: os.makedirs(d + "/sub"))
case("out: view_graph to db.db-wal",
     "view_graph --database_path db.db --output_path db.db-wal")
case("out: view_graph to db.db-journal (absent)",
     "view_graph --database_path db.db --output_path db.db-journal")
case("out: rotation_averager --output_path = --summary_path (new)",
     "rotation_averager --database_path db.db --output_path out_r "
     "--summary_path out_r")
case("out: view_graph to a directory",
     "view_graph --database_path db.db --output_path out_dir",
     lambda d: os.makedirs(d + "/out_dir"))
case("out: view_graph under a file",
     "view_graph --database_path db.db --output_path user_f/x.txt",
     lambda d: open(d + "/user_f", "w").write("mine"))
case("out: view_graph into a new deep directory",
     "view_graph --database_path db.db --output_path out_a/b/c/p.txt")
case("out: view_graph to a symlink to a user file",
     "view_graph --database_path db.db --output_path user_link",
     lambda d: (open(d + "/user_target", "w").write("mine"),
                os.symlink("user_target", d + "/user_link")))
case("out: view_graph to a dangling symlink",
     "view_graph --database_path db.db --output_path user_dangling",
     lambda d: os.symlink("user_made/x.txt", d + "/user_dangling"))
case("out: view_graph to a symlink loop",
     "view_graph --database_path db.db --output_path user_loop",
     lambda d: os.symlink("user_loop", d + "/user_loop"))
case("out: view_graph to a unix socket",
     "view_graph --database_path db.db --output_path user_sock",
     lambda d: __import__("socket").socket(
         __import__("socket").AF_UNIX).bind(d + "/user_sock"))
case("out: view_graph to /dev/newfile (missing under /dev)",
     "view_graph --database_path db.db --output_path /dev/colmap_irav4_x")
case("out: view_graph --output_path ''",
     "view_graph --database_path db.db --output_path ''")
case("out: view_graph --output_path with a newline",
     "view_graph --database_path db.db --output_path $'out_n\\nl.txt'")
case("out: mapper OUT is a file", mapper(),
     lambda d: open(d + "/out", "w").write("mine"))
case("out: mapper OUT is a symlink to a directory", mapper(),
     lambda d: (os.makedirs(d + "/user_dir"),
                os.symlink("user_dir", d + "/out")))
case("out: mapper OUT/0 is a file", mapper(),
     lambda d: (os.makedirs(d + "/out"), open(d + "/out/0", "w").write("x")))
case("out: mapper OUT/0 is a symlink to a user dir", mapper(),
     lambda d: (os.makedirs(d + "/user_dir"), os.makedirs(d + "/out"),
                os.symlink("../user_dir", d + "/out/0")))
case("out: mapper OUT/0/cameras.bin is a directory", mapper(),
     lambda d: os.makedirs(d + "/out/0/cameras.bin"))
case("out: mapper OUT/summary.json is a directory", mapper(),
     lambda d: os.makedirs(d + "/out/summary.json"))
case("out: mapper OUT/0 holds a complete junk .bin model", mapper(),
     lambda d: [os.makedirs(d + "/out/0", exist_ok=True)] +
     [open(d + "/out/0/" + n, "w").write("junk") for n in
      ("cameras.bin", "images.bin", "points3D.bin")])
case("out: mapper twice (second replaces the first)", mapper(),
     lambda d: subprocess.run(BINARY + " " + mapper(), shell=True, cwd=d,
                              capture_output=True))
case("out: mapper OUT under /proc",
     "mapper --database_path db.db --output_path /proc/colmap_irav4_x")
case("out: model_converter to the input directory",
     "model_converter --input_path out/0 --output_path out/0",
     lambda d: subprocess.run(BINARY + " " + mapper(), shell=True, cwd=d,
                              capture_output=True))
case("out: model_viewer --output_path a named pipe",
     "model_viewer --input_path out/0 --output_path fifo.png",
     lambda d: (subprocess.run(BINARY + " " + mapper(), shell=True, cwd=d,
                               capture_output=True),
                os.mkfifo(d + "/fifo.png")))
case("out: model_viewer --output_path = a model file renamed .png",
     "model_viewer --input_path out/0 --output_path out/0/x.png",
     lambda d: (subprocess.run(BINARY + " " + mapper(), shell=True, cwd=d,
                               capture_output=True),
                os.link(d + "/out/0/images.bin", d + "/out/0/x.png")))

# ---------------------------------------------------------------------------
# Options: values through the parser into Check (and the run if accepted).
for flag, values in (
        ("Normalization.extent", ["-inf", "nan", "1e309", "1e-320"]),
        ("Filter.max_reproj_error", ["inf", "nan", "-1", "0"]),
        ("Filter.min_tri_angle", ["inf", "-1", "180", "nan"]),
        ("RotationFilter.max_rotation_error_deg", ["inf", "nan", "1e-9"]),
        ("Mapper.num_threads", ["0", "-5", "100000", "2147483648"]),
        ("Mapper.min_model_size", ["0", "-1", "1", "100000"]),
        ("Mapper.max_num_tracks", ["-1", "2", "600"]),
        ("Mapper.color_image_downscale", ["3", "0", "16"]),
        ("Mapper.seed", ["-1", "1e3", "abc"]),
        ("Mapper.num_ba_iterations", ["-1", "0", "1000000"]),
        ("Tracks.min_track_length", ["0", "1", "1000"]),
        ("BundleAdjustment.loss_scale", ["inf", "nan", "0"]),
        ("BundleAdjustment.max_num_iterations", ["0", "-3"]),
        ("GlobalPositioning.loss_scale", ["inf", "-1"]),
        ("GlobalPositioning.max_num_iterations", ["0"]),
        ("RotationAveraging.theta_deg", ["inf", "0", "nan", "360"]),
        ("Triangulation.max_reproj_error", ["inf", "nan"]),
        ("Triangulation.min_tri_angle", ["-1", "nan"]),
        ("ViewGraph.min_inlier_ratio", ["nan", "2", "-0.5"]),
        ("Mapper.min_num_matches", ["-1", "0", "99999999"]),
        ("Fold.max_fold_score", ["nan", "inf"]),
        ("Mapper.rotation_method", ["nope", ""]),
        ("Mapper.positioning_method", ["nope"]),
        ("output_type", ["bin", "PLY", ""]),
        ("Mapper.progress", ["2", "yes"]),
):
    for value in values:
        case("opt: --%s %s" % (flag, value or "''"),
             mapper("--%s %s" % (flag, value or "''")))
case("opt: unknown flag", mapper("--Mapper.nope 1"))
case("opt: flag without value", mapper("--Normalization.extent"))
case("opt: flag repeated", mapper("--Mapper.seed 1 --Mapper.seed 2"))
case("opt: --image_path is a file", mapper("--image_path db.db"))

# ---------------------------------------------------------------------------
# Database damage.
for name, statements in (
        ("images table dropped", "DROP TABLE images;"),
        ("keypoints blob truncated",
         "UPDATE keypoints SET data = substr(data, 1, 10) WHERE image_id = 1;"),
        ("keypoints rows negative", "UPDATE keypoints SET rows = -1;"),
        ("keypoints cols 3", "UPDATE keypoints SET cols = 3;"),
        ("two_view config 99", "UPDATE two_view_geometries SET config = 99;"),
        ("two_view data NULL", "UPDATE two_view_geometries SET data = NULL;"),
        ("two_view pair_id huge",
         "UPDATE two_view_geometries SET pair_id = 9223372036854775807 "
         "WHERE rowid = 1;"),
        ("two_view F NULL", "UPDATE two_view_geometries SET F = NULL;"),
        ("qvec text", "UPDATE two_view_geometries SET qvec = 'abc';"),
        ("camera width 0", "UPDATE cameras SET width = 0;"),
        ("camera height text", "UPDATE cameras SET height = 'tall';"),
        ("camera params NULL", "UPDATE cameras SET params = NULL;"),
        ("camera model 99", "UPDATE cameras SET model = 99;"),
        ("camera_id NULL in cameras",
         "CREATE TABLE c2 AS SELECT * FROM cameras; DROP TABLE cameras; "
         "ALTER TABLE c2 RENAME TO cameras; UPDATE cameras SET camera_id = "
         "NULL;"),
        ("image camera_id 999", "UPDATE images SET camera_id = 999 WHERE "
         "image_id = 1;"),
        ("image_id text",
         "CREATE TABLE i2 AS SELECT * FROM images; DROP TABLE images; "
         "ALTER TABLE i2 RENAME TO images; UPDATE images SET image_id = 'x' "
         "WHERE image_id = 1;"),
        ("all matches deleted", "DELETE FROM two_view_geometries;"),
        ("one image only", "DELETE FROM images WHERE image_id > 1;"),
        ("empty name", "UPDATE images SET name = '' WHERE image_id = 1;"),
        ("name with a slash and ..",
         "UPDATE images SET name = '../../etc/x.jpg' WHERE image_id = 1;"),
):
    case("db: " + name, mapper(), sql(statements))
case("db: zero-length file", mapper(),
     lambda d: open(d + "/db.db", "w").close())
case("db: random bytes", mapper(),
     lambda d: open(d + "/db.db", "wb").write(os.urandom(4096)))
case("db: truncated to 8 KiB", mapper(),
     lambda d: os.truncate(d + "/db.db", 8192))
case("db: a directory", "mapper --database_path user_d --output_path out",
     lambda d: os.makedirs(d + "/user_d"))
case("db: a named pipe (no writer)",
     "mapper --database_path user_p --output_path out",
     lambda d: os.mkfifo(d + "/user_p"))

# ---------------------------------------------------------------------------
# Model inputs.


def model_then(action):
    def setup(d):
        subprocess.run(BINARY + " " + mapper(), shell=True, cwd=d,
                       capture_output=True)
        action(d)
    return setup


case("model: empty directory",
     "model_converter --input_path in_m --output_path out_c",
     lambda d: os.makedirs(d + "/in_m"))
case("model: images.bin truncated",
     "model_converter --input_path out/0 --output_path out_c",
     model_then(lambda d: os.truncate(d + "/out/0/images.bin", 100)))
case("model: points3D.bin missing",
     "model_converter --input_path out/0 --output_path out_c",
     model_then(lambda d: os.remove(d + "/out/0/points3D.bin")))
case("model: cameras.bin count huge",
     "model_converter --input_path out/0 --output_path out_c",
     model_then(lambda d: open(d + "/out/0/cameras.bin", "r+b").write(
         struct.pack("<Q", 2**60))))
case("model: viewer of a missing model",
     "model_viewer --input_path nope --output_path out_v.png")
case("model: viewer to .gif", "model_viewer --input_path out/0 "
     "--output_path out_v.gif", model_then(lambda d: None))
case("model: viewer width 0", "model_viewer --input_path out/0 "
     "--output_path out_v.png --width 0", model_then(lambda d: None))
case("model: viewer width 100000", "model_viewer --input_path out/0 "
     "--output_path out_v.png --width 100000 --height 100000",
     model_then(lambda d: None))
case("model: comparer against itself",
     "model_comparer --input_path1 out/0 --input_path2 out/0",
     model_then(lambda d: None))
case("model: converter TXT of a model with a space in a name",
     "model_converter --input_path out/0 --output_path out_c "
     "--output_type TXT",
     lambda d: (sql("UPDATE images SET name = 'a b.jpg' WHERE image_id = 1;")
                (d), subprocess.run(BINARY + " " + mapper(), shell=True,
                                    cwd=d, capture_output=True)))


# ---------------------------------------------------------------------------


def run_case(name, args, setup, stdin, shell_suffix):
    scratch = tempfile.mkdtemp(prefix="colmap_irav4_sweep_")
    try:
        shutil.copy(DATABASE, scratch + "/db.db")
        os.chmod(scratch + "/db.db", 0o644)
        if setup:
            try:
                setup(scratch)
            except PermissionError as error:
                return "| %s | skipped | %s | - |" % (name, error)
        before = sha(scratch + "/db.db")
        reader = None
        received = []
        if os.path.exists(scratch + "/fifo") and "fifo" in args:
            # A reader for the pipe, as a user's `cat` would be.
            def read_pipe():
                with open(scratch + "/fifo", "rb") as f:
                    received.append(len(f.read()))
            reader = threading.Thread(target=read_pipe, daemon=True)
            reader.start()
        command = BINARY + " " + args + shell_suffix
        # Its own process group: a run that hangs is killed with its pipe.
        process = subprocess.Popen(
            ["bash", "-c", command + ("; exit ${PIPESTATUS[0]}"
                                      if shell_suffix else "")],
            cwd=scratch, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, errors="replace", start_new_session=True)
        try:
            output, _ = process.communicate(timeout=TIMEOUT)
            code = process.returncode
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, 9)
            process.communicate()
            code, output = "HANG", "(killed after %d s)" % TIMEOUT
        if reader:
            if not received:
                # Unblock a reader the program never wrote to.
                try:
                    fd = os.open(scratch + "/fifo", os.O_WRONLY |
                                 os.O_NONBLOCK)
                    os.close(fd)
                except OSError:
                    pass
            reader.join(2)
        after = sha(scratch + "/db.db")
        db = "db unchanged" if before == after else (
            "DB CHANGED" if after else "DB GONE")
        state = out_state(scratch)
        if received:
            state += "; pipe got %d bytes" % received[0]
        message = first_line(output, code).replace(scratch, "D")
        message = message.replace("|", "\\|")[:220]
        return "| %s | %s | %s | %s; %s |" % (name, code, message, db, state)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main():
    print("| case | exit | first ERROR (else warning) line | on disk |")
    print("| --- | --- | --- | --- |")
    for name, args, setup, stdin, suffix in CASES[SKIP:]:
        if ONLY and not name.startswith(ONLY):
            continue
        print(run_case(name, args, setup, stdin, suffix), flush=True)


if __name__ == "__main__":
    main()
