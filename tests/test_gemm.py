"""baselines.common.gemm: oneDNN's products equal torch's, forward and backward, for the shapes the learners use."""

import pytest
import torch
from torch import nn

from baselines.common import gemm

pytestmark = pytest.mark.skipif(not gemm._ONEDNN_AVAILABLE, reason="this torch build has no oneDNN")


@pytest.mark.parametrize("relu", [False, True])
def test_linear_matches_torch_for_strided_operands(relu):
    g = torch.Generator().manual_seed(0)
    x, weight, bias = torch.randn(300, 70, generator=g), torch.randn(40, 69, generator=g), torch.randn(40, generator=g)
    want = torch.addmm(bias, x[:, 1:], weight.t())
    want = want.relu() if relu else want
    with gemm.backend("onednn"):
        got = gemm.linear(x[:, 1:], weight, bias, relu=relu)  # a column slice: rows strided
        weight_grad = gemm.mm(x.t(), x[:, :40])  # both operands transposed views
    assert got.shape == (300, 40) and torch.allclose(got, want, rtol=1e-5, atol=1e-5)
    assert torch.allclose(weight_grad, x.t() @ x[:, :40], rtol=1e-5, atol=1e-4)


def test_auto_keeps_small_products_on_torch_and_large_ones_where_onednn_is_faster():
    assert not gemm._use_onednn(4, 8, 3) and gemm._use_onednn(1024, 256, 256) == gemm.ONEDNN_PREFERRED
    # "auto" takes oneDNN only where it beat MKL: AVX-512 on AMD (not AVX2 there, not Intel's AVX-512)
    assert gemm.onednn_preferred("AVX512", "AuthenticAMD")
    assert not gemm.onednn_preferred("AVX2", "AuthenticAMD") and not gemm.onednn_preferred("AVX512", "GenuineIntel")
    with gemm.backend("onednn"):
        assert gemm._use_onednn(4, 8, 3)
    with gemm.backend("onednn-large"):  # the rule before processors were told apart
        assert not gemm._use_onednn(4, 8, 3) and gemm._use_onednn(1024, 256, 256)
    with gemm.backend("torch"):
        assert not gemm._use_onednn(1024, 256, 256)


def test_backend_rejects_unknown_names_and_restores_the_previous_one():
    valid = "valid: auto, onednn, onednn-large, torch"
    with pytest.raises(ValueError, match=f"unknown matrix-product backend 'mkl'; {valid}"):
        with gemm.backend("mkl"):
            pass
    with gemm.backend("torch"):
        assert gemm._backend == "torch"
        with pytest.raises(RuntimeError, match="boom"), gemm.backend("onednn"):
            raise RuntimeError("boom")
        assert gemm._backend == "torch"
    assert gemm._backend == "auto"


@pytest.mark.parametrize("backend", ["onednn", "torch"])
def test_linear_module_matches_nn_linear_with_first_and_second_derivatives(backend):
    torch.manual_seed(0)
    reference = nn.Linear(64, 32)
    layer = gemm.Linear(64, 32)
    layer.load_state_dict(reference.state_dict())
    assert list(layer.state_dict()) == ["weight", "bias"]
    x = torch.randn(200, 64, requires_grad=True)
    cotangent = torch.randn(200, 32)
    with gemm.backend(backend):
        out = layer(x)
        grads = torch.autograd.grad((out * cotangent).sum(), [x, layer.weight, layer.bias], create_graph=True)
        # second order, as the autograd Fisher takes it: d/dW of (dL/dx . v)
        (second,) = torch.autograd.grad((grads[0] * x.detach()).sum(), layer.weight)
    want = reference(x)
    want_grads = torch.autograd.grad((want * cotangent).sum(), [x, reference.weight, reference.bias],
                                     create_graph=True)
    (want_second,) = torch.autograd.grad((want_grads[0] * x.detach()).sum(), reference.weight)
    assert torch.allclose(out, want, rtol=1e-5, atol=1e-5)
    for got, expected in zip(grads, want_grads, strict=True):
        assert torch.allclose(got, expected, rtol=1e-5, atol=1e-4)
    assert torch.allclose(second, want_second, rtol=1e-5, atol=1e-4)
