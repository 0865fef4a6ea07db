"""Matrix products of the hand-differentiated off-policy learner, run by oneDNN where torch's BLAS is slower.

PyTorch's CPU wheels send fp32 ``torch.mm`` to MKL, which on AMD processors runs its AVX2 kernels: 105 GFLOP/s
on one Zen 5 core for ``[1024, 256] @ [256, 256]``, where oneDNN (also inside the wheel, reached through
``torch.ops.mkldnn._linear_pointwise``) runs AVX-512 kernels at 205-248 GFLOP/s, in full fp32 (no reduced-precision
math mode), for the three shapes of a layer's forward, input-gradient and weight-gradient products (transposed
operands are passed as strided views, no copies). Small products stay with ``torch.mm``: oneDNN's ~10 us call
costs more than it saves below ~1M multiply-adds. On an AVX2 processor (Zen 2/3, no AVX-512) it is the other way
round: MKL ran those three shapes at 78-84 GFLOP/s per core against oneDNN's 56-74, so ``"auto"`` sends products to
oneDNN only on AMD processors with AVX-512 (:data:`ONEDNN_PREFERRED`); on Intel, MKL has AVX-512 kernels of its own.

:func:`linear` is ``act(x @ w.T + b)`` (``F.linear``'s layout, bias and ReLU fused); :func:`mm` is ``a @ b``;
:class:`Linear` is ``nn.Linear`` on them, differentiable (what :func:`~baselines.common.networks.build_mlp` builds).
:func:`backend` picks the path (``"auto"``, ``"onednn"``, ``"torch"``) for a block, as tests do to check both.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import torch
from torch import nn

BACKENDS = ("auto", "onednn", "onednn-large", "torch")
MIN_ONEDNN_MACS = 1 << 20  # below it torch.mm wins (measured: 512x256x1 7.7 against 15 us; 1024x68x256 372 against 176)

_ONEDNN_AVAILABLE = torch.backends.mkldnn.is_available() and hasattr(torch.ops.mkldnn, "_linear_pointwise")


def cpu_vendor() -> str:
    """The processor's vendor string (``AuthenticAMD``, ``GenuineIntel``), or ``""`` where /proc/cpuinfo is absent."""
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                if line.startswith("vendor_id"):
                    return line.partition(":")[2].strip()
    except OSError:
        pass
    return ""


def onednn_preferred(capability: str, vendor: str) -> bool:
    """Whether ``"auto"`` uses oneDNN for large products on a processor with torch's ``capability`` ("AVX512",
    "AVX2", ...) from ``vendor``: only where it was measured faster than MKL, AVX-512 on AMD."""
    return _ONEDNN_AVAILABLE and capability == "AVX512" and vendor == "AuthenticAMD"


ONEDNN_PREFERRED = onednn_preferred(torch.backends.cpu.get_cpu_capability(), cpu_vendor())
_backend = "auto"


@contextlib.contextmanager
def backend(name: str) -> Iterator[None]:
    """Within the block, products run on ``name``: ``"auto"`` (oneDNN for large products where
    :data:`ONEDNN_PREFERRED`, else torch's), ``"onednn"`` (all products; an error if this torch has no oneDNN),
    ``"onednn-large"`` (large products on oneDNN whatever the processor: ``"auto"`` before 2026-11-29, kept for
    benchmarks) or ``"torch"`` (``torch.mm`` / ``torch.addmm``)."""
    global _backend
    if name not in BACKENDS:
        raise ValueError(f"unknown matrix-product backend {name!r}; valid: {', '.join(BACKENDS)}")
    if name.startswith("onednn") and not _ONEDNN_AVAILABLE:
        raise RuntimeError("this torch build has no oneDNN (torch.backends.mkldnn.is_available() is False)")
    previous, _backend = _backend, name
    try:
        yield
    finally:
        _backend = previous


def _use_onednn(rows: int, inner: int, cols: int) -> bool:
    if _backend in ("auto", "onednn-large"):
        preferred = ONEDNN_PREFERRED if _backend == "auto" else _ONEDNN_AVAILABLE
        return preferred and rows * inner * cols >= MIN_ONEDNN_MACS
    return _backend == "onednn"


def linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None = None, relu: bool = False) -> torch.Tensor:
    """``x @ weight.T (+ bias)``, then ReLU if ``relu``: ``x`` ``(N, in)``, ``weight`` ``(out, in)`` (views allowed),
    ``bias`` ``(out,)``. A fresh ``(N, out)`` tensor. oneDNN's op has no derivative, so where autograd records (an
    input requires grad) the product is torch's."""
    records = torch.is_grad_enabled() and (x.requires_grad or weight.requires_grad)
    if not records and _use_onednn(x.shape[0], x.shape[1], weight.shape[0]):
        return torch.ops.mkldnn._linear_pointwise(x, weight, bias, "relu" if relu else "none", [], "")
    out = torch.mm(x, weight.t()) if bias is None else torch.addmm(bias, x, weight.t())
    return out.relu_() if relu else out


def mm(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """``a @ b`` for ``a`` ``(N, K)`` and ``b`` ``(K, M)`` (views allowed, such as ``g.t()`` for weight gradients)."""
    return linear(a, b.t())


class _LinearFunction(torch.autograd.Function):
    """``x @ weight.T + bias`` with its backward on :func:`mm`; a double backward (``create_graph``) records torch's
    products instead, since :func:`linear` falls back to them wherever autograd records."""

    @staticmethod
    def forward(ctx, x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
        ctx.save_for_backward(x, weight)
        ctx.has_bias = bias is not None
        return linear(x, weight, bias)

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        x, weight = ctx.saved_tensors
        grad_x = mm(grad, weight) if ctx.needs_input_grad[0] else None
        grad_weight = mm(grad.t(), x) if ctx.needs_input_grad[1] else None
        grad_bias = grad.sum(0) if ctx.has_bias and ctx.needs_input_grad[2] else None
        return grad_x, grad_weight, grad_bias


class Linear(nn.Linear):
    """``nn.Linear`` (same parameters and state dict) whose products forward and backward go through :func:`linear`
    and :func:`mm` for 2-D float32 CPU inputs; anything else is ``nn.Linear``'s."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.dim() != 2 or x.dtype != torch.float32 or x.device.type != "cpu" or _backend == "torch":
            return super().forward(x)
        return _LinearFunction.apply(x, self.weight, self.bias)
