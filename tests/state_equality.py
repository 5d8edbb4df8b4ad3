"""Exact equality of nested training states (tensors, dicts, lists, plain values)."""

import torch


def assert_equal_state(a, b, where: str = "state") -> None:
    """Assert `a` and `b` are equal leaf for leaf (tensors bit for bit); name the leaf."""
    if isinstance(a, torch.Tensor):
        assert torch.equal(a, b), f"{where} differs"
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            assert_equal_state(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_equal_state(x, y, f"{where}[{i}]")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"
