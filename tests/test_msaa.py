"""Stochastic MSAA's compiled passes against their plain-torch twins, and what they mean."""

from __future__ import annotations

import pytest
import torch

from lookalike.render.msaa import (
    covered_sample_index,
    covered_sample_index_python,
    pick_samples,
    pick_samples_python,
    upsample_over,
    upsample_over_python,
)


def sample_ids(batch: int, height: int, width: int, factor: int, seed: int = 0) -> torch.Tensor:
    """``[B, H f, W f]`` float triangle ids, about half the samples covered (some blocks full,
    some empty)."""
    generator = torch.Generator().manual_seed(seed)
    ids = torch.randint(1, 9, (batch, height * factor, width * factor), generator=generator).float()
    keep = torch.rand(ids.shape, generator=generator) < 0.5
    keep[:, :factor, :factor] = True  # a full block
    keep[:, -factor:, -factor:] = False  # an empty one
    return ids * keep


@pytest.mark.parametrize("factor", [1, 2, 3])
def test_covered_sample_index_matches_twin(factor):
    ids = sample_ids(2, 5, 4, factor)
    u = torch.rand(2, 5, 4, generator=torch.Generator().manual_seed(1))
    u[0, 0, 0], u[0, 0, 1] = 0.0, 1.0 - 1e-7  # the ends of the range
    fast = covered_sample_index(ids, u, factor)
    assert torch.equal(fast, covered_sample_index_python(ids, u, factor))
    chosen = ids.reshape(-1)[fast]
    blocks = ids.reshape(2, 5, factor, 4, factor).permute(0, 1, 3, 2, 4).reshape(2, 5, 4, -1)
    any_covered = (blocks > 0).any(-1)
    assert bool((chosen[any_covered] > 0).all()), "a covered sample whenever the block has one"
    rows, cols = fast // (4 * factor) % (5 * factor), fast % (4 * factor)
    assert torch.equal(rows // factor, torch.arange(5)[None, :, None].expand(2, 5, 4))
    assert torch.equal(cols // factor, torch.arange(4)[None, None, :].expand(2, 5, 4))


def test_covered_sample_index_is_uniform_over_the_covered_samples():
    ids = torch.tensor([[[0.0, 3.0], [5.0, 7.0]]])  # one 2x2 block, three covered
    u = torch.rand(3000, generator=torch.Generator().manual_seed(2))
    picks = torch.stack([covered_sample_index(ids, x.reshape(1, 1, 1), 2)[0, 0, 0] for x in u])
    counts = torch.bincount(picks, minlength=4).float() / picks.numel()
    assert counts[0] == 0
    torch.testing.assert_close(counts[1:], torch.full((3,), 1 / 3), atol=0.03, rtol=0)


def test_picking_samples_matches_twin_in_values_and_gradients():
    ids = sample_ids(2, 4, 3, 2, seed=6)
    index = covered_sample_index(ids, torch.rand(2, 4, 3, generator=torch.Generator().manual_seed(7)), 2)
    image = torch.rand(2, 8, 6, 4, dtype=torch.float64, requires_grad=True)
    fast, slow = pick_samples(image, index), pick_samples_python(image, index)
    torch.testing.assert_close(fast, slow)
    weights = torch.randn(fast.shape, dtype=torch.float64)
    fast_grad, = torch.autograd.grad((fast * weights).sum(), image)
    slow_grad, = torch.autograd.grad((slow * weights).sum(), image)
    torch.testing.assert_close(fast_grad, slow_grad)
    assert int((fast_grad != 0).any(-1).sum()) == index.numel()


@pytest.mark.parametrize("factor", [1, 2, 3])
def test_upsample_over_matches_twin_in_values_and_gradients(factor):
    generator = torch.Generator().manual_seed(3)
    ids = sample_ids(2, 4, 3, factor, seed=4)
    accum = torch.rand(2, 4 * factor, 3 * factor, 4, generator=generator, dtype=torch.float64, requires_grad=True)
    colour = torch.rand(2, 4, 3, 4, generator=generator, dtype=torch.float64, requires_grad=True)
    fast = upsample_over(accum, colour, ids, factor)
    slow = upsample_over_python(accum, colour, ids, factor)
    torch.testing.assert_close(fast, slow)
    weights = torch.randn(fast.shape, generator=generator, dtype=torch.float64)
    fast_grads = torch.autograd.grad((fast * weights).sum(), (accum, colour))
    slow_grads = torch.autograd.grad((slow * weights).sum(), (accum, colour))
    torch.testing.assert_close(fast_grads, slow_grads)


def test_upsample_over_gradients_match_finite_differences():
    ids = sample_ids(1, 2, 2, 2, seed=5)
    accum = torch.rand(1, 4, 4, 4, dtype=torch.float64, requires_grad=True)
    colour = torch.rand(1, 2, 2, 4, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda a, c: upsample_over(a, c, ids, 2), (accum, colour))


def test_upsample_over_covers_only_covered_samples():
    ids = torch.tensor([[[1.0, 0.0], [0.0, 2.0]]])
    accum = torch.zeros(1, 2, 2, 4)
    colour = torch.tensor([[[[0.2, 0.4, 0.6, 0.5]]]])
    out = upsample_over(accum, colour, ids, 2)
    expected = torch.tensor([[0.1, 0.2, 0.3, 0.5], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3, 0.5]])
    torch.testing.assert_close(out.reshape(4, 4), expected)
    with pytest.raises(ValueError, match="blocks"):
        upsample_over(accum, colour, ids[:, :1], 2)
