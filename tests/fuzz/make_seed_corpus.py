#!/usr/bin/env python3
"""Writes the small seed corpora of the libFuzzer targets (tests/fuzz/corpus).

Inputs with several parts start with 16-bit little-endian lengths of all
parts but the last (tests/fuzz/fuzz_utils.h, SplitInput).
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def parts(*items):
    header = b"".join(struct.pack("<H", len(p)) for p in items[:-1])
    return header + b"".join(items)


def write(target, name, data):
    directory = os.path.join(HERE, "corpus", target)
    os.makedirs(directory, exist_ok=True)
    with open(os.path.join(directory, name), "wb") as f:
        f.write(data)


def model_bin():
    cameras = struct.pack("<Q", 1) + struct.pack("<IiQQ", 1, 0, 100, 80) + \
        struct.pack("<3d", 90.0, 50.0, 40.0)
    images = struct.pack("<Q", 2)
    for image_id, name in ((1, b"a.jpg"), (2, b"b.jpg")):
        images += struct.pack("<I", image_id)
        images += struct.pack("<4d", 1.0, 0.0, 0.0, 0.0)
        images += struct.pack("<3d", float(image_id), 0.0, 0.0)
        images += struct.pack("<I", 1) + name + b"\0"
        images += struct.pack("<Q", 2)
        images += struct.pack("<ddQ", 10.0, 20.0, 7)
        images += struct.pack("<ddQ", 30.0, 40.0, 2**64 - 1)
    points = struct.pack("<Q", 1) + struct.pack("<Q", 7) + \
        struct.pack("<3d", 0.5, 0.2, 4.0) + struct.pack("<3B", 10, 20, 30) + \
        struct.pack("<d", 0.5) + struct.pack("<Q", 2) + \
        struct.pack("<II", 1, 0) + struct.pack("<II", 2, 0)
    write("model_bin_fuzzer", "two_images", parts(cameras, images, points))
    write("model_bin_fuzzer", "empty", parts(struct.pack("<Q", 0),
                                             struct.pack("<Q", 0),
                                             struct.pack("<Q", 0)))


def text_readers():
    q = " 1 0 0 0 0 0 1"
    write("text_readers_fuzzer", "relpose",
          b"\x00" + f"a b{q} 20\nb c{q} 30\na c{q} 25\n".encode())
    write("text_readers_fuzzer", "rotations",
          b"\x01a 1 0 0 0\nb 0.7071068 0.7071068 0 0\n")
    write("text_readers_fuzzer", "egs",
          b"\x020 1 1 0 0 0 1 0 0 0 1 0 0 1\n1 2 1 0 0 0 1 0 0 0 1 1 0 0\n")
    write("text_readers_fuzzer", "list", b"\x03images/a.jpg 0 512.5\nimages/b.jpg\n")
    write("text_readers_fuzzer", "bundler",
          b"\x04# Bundle file v0.3\n2 1\n500 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n"
          b"0 0 0\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n1 2 3\n255 0 0\n1 0 3 4.5 6.5\n")
    write("text_readers_fuzzer", "strecha",
          b"\x052759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n0 0 0\n"
          b"0.45 -0.02 0.89\n-0.89 0.02 0.45\n0.0 -0.99 0.02\n"
          b"-7.8 2.3 1.3\n3072 2048\n")
    cameras = b"# c\n1 PINHOLE 100 80 90 90 50 40\n"
    images = b"1 1 0 0 0 0 0 0 1 a.jpg\n10 20 7 30 40 -1\n" \
             b"2 1 0 0 0 1 0 0 1 b.jpg\n10 20 7\n"
    points = b"7 0.5 0.2 4 10 20 30 0.5 1 0 2 0\n"
    write("text_readers_fuzzer", "txt_model",
          b"\x07" + parts(cameras, images, points))


def database():
    pair_id = 2147483647 * 1 + 2
    fields = [
        struct.pack("<q", 1),  # model PINHOLE
        struct.pack("<q", 100), struct.pack("<q", 80),
        struct.pack("<4d", 90.0, 90.0, 50.0, 40.0),
        struct.pack("<q", 1),
        struct.pack("<q", 3), struct.pack("<q", 2),
        struct.pack("<6f", 10, 20, 30, 40, 50, 60),
        struct.pack("<q", 3), struct.pack("<q", 6),
        struct.pack("<18f", *range(18)),
        struct.pack("<q", pair_id), struct.pack("<q", 2), struct.pack("<q", 2),
        struct.pack("<4I", 0, 1, 2, 0),
        struct.pack("<q", 2),
        struct.pack("<9d", 0, 0, 0, 0, 0, -1, 0, 1, 0),
        struct.pack("<9d", 0, 0, 0, 0, 0, -1, 0, 1, 0),
        struct.pack("<9d", 1, 0, 0, 0, 1, 0, 0, 0, 1),
        struct.pack("<4d", 1, 0, 0, 0) + struct.pack("<3d", 1, 0, 0),
    ]
    write("database_fuzzer", "one_pair", parts(*fields))


def options():
    # mapper: --Normalization.extent and a few others by number, values from
    # the fuzzer's list (< 128) or from the input's bytes (>= 128).
    write("options_fuzzer", "mapper", bytes([0, 5, 4, 9, 200]) + b"1e308\0" +
          bytes([30, 1, 31, 2]))
    write("options_fuzzer", "view_graph", bytes([1, 0, 1, 3, 5]))
    write("options_fuzzer", "rotation_averager", bytes([2, 2, 3, 7, 129]) +
          b"-3\0")


def output_paths():
    # Single files: db.db, link.db, dir/cameras.bin, new/new; model
    # directories: model, dir, dangling.
    for name, data in (("file_db", [0, 0]), ("file_link", [0, 1]),
                       ("file_in_dir", [0, 3, 6]), ("file_new", [0, 12, 12]),
                       ("model", [1, 4]), ("model_dir", [1, 3]),
                       ("model_dangling", [1, 14])):
        write("output_paths_fuzzer", name, bytes(data))


if __name__ == "__main__":
    model_bin()
    text_readers()
    database()
    options()
    output_paths()
