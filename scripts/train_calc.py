#!/usr/bin/env python3
"""Trains the CALC-style convolutional encoder without labels and exports it to ONNX.

Recipe (Merrill & Huang, RSS 2018; ../shared/docs/methods.md section 1): pairs of an image and a
random perspective warp of it; the encoder (conv1-conv3) plus a fully connected decoder
reconstructs the HOG of the *other* image of the pair; squared error. Only the encoder is kept.

Training images: the photographs that Debian's python3-skimage package ships, limited to those
its documentation marks CC0 or public domain (TRAINING_IMAGES below). Nothing is downloaded.
Random crops at many scales, flips, warps and lighting changes turn them into endless pairs.

usage: scripts/train_calc.py [--steps 800] [--output model/calc_encoder.onnx]
                             [--checkpoint _train/calc_checkpoint.pt] [--seed 1]
The default 800 steps of 32 pairs take about 25 minutes on 2 CPU cores. Resumes from the
checkpoint when it exists (delete it to start over); the same seed and steps give the same model.
--export-only writes the checkpoint's encoder without training further.
"""
import argparse
import math
import os
import random
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from PIL import Image

HEIGHT, WIDTH = 120, 160

# scikit-image sample photographs and their terms, as documented in skimage/data/_fetchers.py.
TRAINING_IMAGES = {
    "astronaut.png": "public domain (NASA)",
    "brick.png": "CC0 (CC0Textures)",
    "camera.png": "CC0 (Lav Varshney)",
    "chelsea.png": "CC0 (Stefan van der Walt)",
    "coffee.png": "CC0 (Rachel Michetti)",
    "grass.png": "CC0 (CC0Textures)",
    "gravel.png": "CC0 (CC0Textures)",
    "rocket.jpg": "public domain (SpaceX)",
    "hubble_deep_field.jpg": "public domain (NASA)",
    "coins.png": "no known copyright restrictions",
    "text.png": "public domain",
    "clock_motion.png": "public domain (Stefan van der Walt)",
}


class _LrnExport(torch.autograd.Function):
    """Exports local response normalisation as the standard ONNX LRN op (which OpenCV's dnn
    module runs) rather than PyTorch's decomposition into pads and pools."""

    @staticmethod
    def forward(ctx, x):
        return F.local_response_norm(x, 5, alpha=1e-4, beta=0.75, k=1.0)

    @staticmethod
    def symbolic(g, x):
        return g.op("LRN", x, size_i=5, alpha_f=1e-4, beta_f=0.75, bias_f=1.0)


class Lrn(nn.Module):
    def forward(self, x):
        if torch.onnx.is_in_onnx_export():
            return _LrnExport.apply(x)
        return F.local_response_norm(x, 5, alpha=1e-4, beta=0.75, k=1.0)


class CalcEncoder(nn.Module):
    """conv1 5x5/64 s2 p4 -> ReLU -> maxpool 3/2 -> LRN -> conv2 4x4/128 p2 -> ReLU -> maxpool
    3/2 -> LRN -> conv3 3x3/4 -> ReLU; pooling rounds up (Caffe). 1x120x160 -> 4x14x19."""

    def __init__(self):
        super().__init__()
        self.conv1 = nn.Conv2d(1, 64, 5, stride=2, padding=4)
        self.conv2 = nn.Conv2d(64, 128, 4, stride=1, padding=2)
        self.conv3 = nn.Conv2d(128, 4, 3, stride=1)
        self.pool = nn.MaxPool2d(3, stride=2, ceil_mode=True)
        self.norm = Lrn()

    def forward(self, x):
        x = self.norm(self.pool(F.relu(self.conv1(x))))
        conv2 = F.relu(self.conv2(x))
        x = self.norm(self.pool(conv2))
        conv3 = F.relu(self.conv3(x))
        return conv2, conv3


class CalcAutoencoder(nn.Module):
    def __init__(self):
        super().__init__()
        self.encoder = CalcEncoder()
        self.decoder = nn.Sequential(
            nn.Linear(1064, 1064), nn.Sigmoid(), nn.Linear(1064, 2048), nn.Sigmoid(),
            nn.Linear(2048, 3648), nn.Sigmoid())

    def forward(self, x):
        _, code = self.encoder(x)
        return self.decoder(code.flatten(1))


def calc_hog(images):
    """HOG in CALC's layout for a batch (N x 1 x 120 x 160, values 0..1): unsigned gradients,
    2 orientation bins with linear voting, 8x8 cells, 16x16 blocks L2-Hys normalised, windows of
    16x32 (one block wide, two tall) every 8 pixels -> 19 x 12 windows x 16 = 3648 values. It
    follows OpenCV's HOGDescriptor without its Gaussian block window and spatial interpolation:
    a training target, not a descriptor."""
    dx = F.pad(images[..., :, 2:] - images[..., :, :-2], (1, 1, 0, 0))
    dy = F.pad(images[..., 2:, :] - images[..., :-2, :], (0, 0, 1, 1))
    magnitude = torch.sqrt(dx * dx + dy * dy + 1e-12)
    angle = torch.remainder(torch.atan2(dy, dx), math.pi)  # [0, pi)
    position = angle / (math.pi / 2) - 0.5  # Bin centres at 45 and 135 degrees.
    low = torch.floor(position)
    weight_high = position - low
    low_bin = torch.remainder(low, 2)
    votes = []
    for b in (0, 1):
        votes.append(magnitude * ((low_bin == b).float() * (1 - weight_high) +
                                  (torch.remainder(low_bin + 1, 2) == b).float() * weight_high))
    cells = F.avg_pool2d(torch.cat(votes, 1), 8) * 64  # N x 2 x 15 x 20
    blocks = torch.cat([cells[:, :, :-1, :-1], cells[:, :, :-1, 1:], cells[:, :, 1:, :-1],
                        cells[:, :, 1:, 1:]], 1)  # N x 8 x 14 x 19
    blocks = blocks / (blocks.norm(dim=1, keepdim=True) + 1e-3)
    blocks = blocks.clamp(max=0.2)
    blocks = blocks / (blocks.norm(dim=1, keepdim=True) + 1e-3)
    windows = torch.cat([blocks[:, :, :-2], blocks[:, :, 2:]], 1)  # N x 16 x 12 x 19
    return windows.permute(0, 2, 3, 1).reshape(images.shape[0], -1)


def homography(source, target):
    rows = []
    for (x, y), (u, v) in zip(source, target):
        rows.append([x, y, 1, 0, 0, 0, -u * x, -u * y, -u])
        rows.append([0, 0, 0, x, y, 1, -v * x, -v * y, -v])
    _, _, vt = np.linalg.svd(np.asarray(rows))
    return (vt[-1] / vt[-1, -1]).reshape(3, 3)


def perspective_warp(image, rng):
    """Moves each corner inwards by up to a quarter of the image (CALC's warp) and resamples."""
    w, h = WIDTH - 1, HEIGHT - 1
    corners = [(0, 0), (w, 0), (w, h), (0, h)]
    directions = [(1, 1), (-1, 1), (-1, -1), (1, -1)]
    moved = [(x + dx * rng.uniform(0, w / 4), y + dy * rng.uniform(0, h / 4))
             for (x, y), (dx, dy) in zip(corners, directions)]
    # Map output pixels back into the input: output corners = image corners.
    inverse = homography(corners, moved)
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float64)
    points = inverse @ np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    grid = np.stack([points[0] / points[2] / w * 2 - 1, points[1] / points[2] / h * 2 - 1], -1)
    grid = torch.from_numpy(grid.reshape(1, HEIGHT, WIDTH, 2)).float()
    return F.grid_sample(image[None], grid, align_corners=True, padding_mode="border")[0]


def random_view(photo, rng):
    """A 160x120 grey crop at a random scale, position and lighting, maybe mirrored."""
    h, w = photo.shape
    scale = rng.uniform(0.35, 1.0)
    crop_h = int(min(h, w * 3 / 4) * scale)
    crop_w = int(crop_h * 4 / 3)
    top = rng.randint(0, h - crop_h)
    left = rng.randint(0, w - crop_w)
    crop = Image.fromarray(photo[top:top + crop_h, left:left + crop_w])
    view = np.asarray(crop.resize((WIDTH, HEIGHT), Image.BICUBIC), dtype=np.float32) / 255.0
    if rng.random() < 0.5:
        view = view[:, ::-1].copy()
    return torch.from_numpy(view)[None]


def relight(image, rng):
    gamma = rng.uniform(0.7, 1.4)
    out = image.clamp(0, 1) ** gamma * rng.uniform(0.7, 1.2) + rng.uniform(-0.1, 0.1)
    return (out + torch.randn_like(out) * 0.01).clamp(0, 1)


def load_photos():
    try:
        import skimage
    except ImportError:
        sys.exit("python3-skimage is missing: apt-get install python3-skimage")
    folder = os.path.join(os.path.dirname(skimage.__file__), "data")
    photos = []
    for name in sorted(TRAINING_IMAGES):
        path = os.path.join(folder, name)
        if not os.path.exists(path):
            sys.exit("training image %s is missing from python3-skimage" % path)
        photos.append(np.asarray(Image.open(path).convert("L")))
    return photos


def batch(photos, size, rng):
    inputs, targets = [], []
    for _ in range(size):
        view = random_view(photos[rng.randrange(len(photos))], rng)
        warped = perspective_warp(view, rng)
        first, second = (view, warped) if rng.random() < 0.5 else (warped, view)
        inputs.append(relight(first, rng))
        targets.append(second)
    return torch.stack(inputs), calc_hog(torch.stack(targets))


def export(encoder, path):
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    encoder.eval()
    torch.onnx.export(encoder, torch.zeros(1, 1, HEIGHT, WIDTH), path, input_names=["image"],
                      output_names=["conv2", "conv3"], opset_version=11)
    print("exported", path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=800)
    parser.add_argument("--output", default="model/calc_encoder.onnx")
    parser.add_argument("--checkpoint", default="_train/calc_checkpoint.pt")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--export-only", action="store_true",
                        help="export the checkpoint's encoder without training")
    args = parser.parse_args()
    torch.set_num_threads(2)
    torch.manual_seed(args.seed)
    rng = random.Random(args.seed)
    photos = load_photos()
    model = CalcAutoencoder()
    optimizer = torch.optim.Adam(model.parameters(), lr=5e-4)
    step = 0
    spent = 0.0
    if os.path.exists(args.checkpoint):
        state = torch.load(args.checkpoint)
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        step, spent = state["step"], state["seconds"]
        rng.setstate(state["python_rng"])
        torch.set_rng_state(state["torch_rng"])
        print("resumed at step %d after %.1f min" % (step, spent / 60))
    if args.export_only:
        export(model.encoder, args.output)
        return 0
    os.makedirs(os.path.dirname(args.checkpoint) or ".", exist_ok=True)

    def save():
        torch.save({"model": model.state_dict(), "optimizer": optimizer.state_dict(),
                    "step": step, "seconds": spent, "python_rng": rng.getstate(),
                    "torch_rng": torch.get_rng_state()}, args.checkpoint)

    start = time.time() - spent
    last_save = time.time()
    running = None
    while step < args.steps:
        inputs, targets = batch(photos, args.batch, rng)
        loss = F.mse_loss(model(inputs), targets)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        step += 1
        spent = time.time() - start
        running = loss.item() if running is None else 0.98 * running + 0.02 * loss.item()
        if step % 20 == 0:
            print("step %d  %.1f min  loss %.5f" % (step, spent / 60, running), flush=True)
        if time.time() - last_save > 120:
            save()
            last_save = time.time()
    save()
    export(model.encoder, args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
