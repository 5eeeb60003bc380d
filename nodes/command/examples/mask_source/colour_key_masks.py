#!/usr/bin/env python3
"""A mask source for the `command` stage, in plain Python (standard library only).

    python3 colour_key_masks.py FRAMES_DIR OUT_DIR OPTIONS_JSON

Reads a Frames artifact (frames.json and the 8-bit PNGs it names) and writes one
DAVIS-style mask per frame, OUT_DIR/<frame stem>.png: an indexed (palette) PNG whose
pixel value is the object id, 0 = background, with the DAVIS/VOC palette, as SAM 2's
video predictor writes them. `import_masks` with `format: "davis"` reads them.

The "segmentation" is a colour key, standing in for a real model: pixel -> the first
colour of options["colours"] (a list of [r, g, b]) within options["tolerance"] on every
channel, whose position + 1 is the object id. Swap this function for SAM 2 and the rest
of the file (reading frames, writing DAVIS PNGs) stays.

Errors go to stderr with a non-zero exit; the stage quotes them.
"""
import json
import os
import struct
import sys
import zlib

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def fail(message):
    print(f"colour_key_masks: {message}", file=sys.stderr)
    sys.exit(1)


def read_png_rgb(path):
    """(width, height, rows of (r, g, b) tuples) of an 8-bit grey/RGB/RGBA PNG."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(PNG_SIGNATURE):
        fail(f"{path}: not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    width, height, depth, colour, _, _, interlace = header
    channels = {0: 1, 2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace != 0:
        fail(f"{path}: only 8-bit, non-interlaced grey/RGB/RGBA PNGs are read here")
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous = [], bytearray(stride)
    for y in range(height):
        start = y * (stride + 1)
        kind, line = raw[start], bytearray(raw[start + 1:start + 1 + stride])
        for i in range(stride):
            left = line[i - channels] if i >= channels else 0
            up = previous[i]
            up_left = previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + left) & 255
            elif kind == 2:
                line[i] = (line[i] + up) & 255
            elif kind == 3:
                line[i] = (line[i] + (left + up) // 2) & 255
            elif kind == 4:
                p = left + up - up_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                predictor = left if pa <= pb and pa <= pc else (up if pb <= pc else up_left)
                line[i] = (line[i] + predictor) & 255
        previous = line
        if channels == 1:
            rows.append([(v, v, v) for v in line])
        else:
            rows.append([tuple(line[x * channels:x * channels + 3]) for x in range(width)])
    return width, height, rows


def davis_palette():
    """The DAVIS/VOC colour map: each index's bits interleaved into R, G, B."""
    palette = bytearray()
    for index in range(256):
        r = g = b = 0
        c = index
        for j in range(8):
            r |= ((c >> 0) & 1) << (7 - j)
            g |= ((c >> 1) & 1) << (7 - j)
            b |= ((c >> 2) & 1) << (7 - j)
            c >>= 3
        palette += bytes((r, g, b))
    return bytes(palette)


def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def write_indexed_png(path, width, height, ids):
    raw = b"".join(b"\x00" + bytes(row) for row in ids)
    png = PNG_SIGNATURE
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 3, 0, 0, 0))
    png += chunk(b"PLTE", davis_palette())
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def colour_key(rows, colours, tolerance):
    def object_of(pixel):
        for i, key in enumerate(colours):
            if all(abs(p - k) <= tolerance for p, k in zip(pixel, key)):
                return i + 1
        return 0

    return [[object_of(p) for p in row] for row in rows]


def main():
    if len(sys.argv) != 4:
        fail("usage: colour_key_masks.py FRAMES_DIR OUT_DIR OPTIONS_JSON")
    frames_dir, out_dir, options_path = sys.argv[1:]
    with open(options_path) as f:
        options = json.load(f)
    colours = options.get("colours")
    if not colours or any(len(c) != 3 for c in colours):
        fail('options: "colours" must be a non-empty list of [r, g, b]')
    if len(colours) > 254:
        fail("options: at most 254 colours fit a DAVIS mask")
    tolerance = options.get("tolerance", 30)
    with open(os.path.join(frames_dir, "frames.json")) as f:
        frames = json.load(f)
    for frame in frames:
        width, height, rows = read_png_rgb(os.path.join(frames_dir, frame["image"]))
        if (width, height) != (frame["width"], frame["height"]):
            fail(f"{frame['image']}: {width}x{height}, but frames.json says {frame['width']}x{frame['height']}")
        ids = colour_key(rows, colours, tolerance)
        stem = os.path.splitext(os.path.basename(frame["name"]))[0]
        write_indexed_png(os.path.join(out_dir, stem + ".png"), width, height, ids)
    print(f"colour_key_masks: {len(frames)} frames", file=sys.stderr)


if __name__ == "__main__":
    main()
