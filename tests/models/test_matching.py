"""Ground-truth matching by GEMM against a brute-force pairwise loop."""

from __future__ import annotations

import pytest
import torch

from synthcal.models.losses import mse_loss, one_hot_maps, top_mse_loss
from synthcal.models.matching import class_code, match_ground_truth, merge_matches, pairwise_scores

SCORE_FN = {"mse": mse_loss, "top_mse": top_mse_loss}


def _brute_force(queries: torch.Tensor, templates: torch.Tensor, score: str,
                 class_reduction: str = "sum") -> torch.Tensor:
    """(Q, T) scores, one pair at a time, with the training losses."""
    fn = SCORE_FN[score]
    out = torch.empty(len(queries), len(templates), dtype=torch.float64)
    for i in range(len(queries)):
        for j in range(len(templates)):
            out[i, j] = fn(queries[i:i + 1], templates[j:j + 1], reduction="none", class_reduction=class_reduction)[0]
    return out


def _first_argmin(scores: torch.Tensor) -> torch.Tensor:
    return torch.tensor([min(range(len(row)), key=lambda j: (row[j].item(), j)) for row in scores])


def _class_id_sets(seed: int, size: tuple[int, int], num_classes: int = 4):
    g = torch.Generator().manual_seed(seed)
    queries = torch.randint(0, num_classes, (7, *size), generator=g)
    templates = torch.randint(0, num_classes, (11, *size), generator=g)
    # Exact matches, a duplicated template (a tie) and near-copies of queries.
    templates[2] = queries[0]
    templates[5] = templates[8] = queries[3]
    near = queries[4].clone()
    near[: size[0] // 3] = torch.randint(0, num_classes, near[: size[0] // 3].shape, generator=g)
    templates[9] = near
    return queries, templates


@pytest.mark.parametrize("score", ["mse", "top_mse"])
@pytest.mark.parametrize("size", [(16, 24), (18, 30)])
@pytest.mark.parametrize("reduction", ["sum", "mean"])
def test_class_ids_equal_brute_force(score, size, reduction):
    queries, templates = _class_id_sets(3, size)
    brute = _brute_force(one_hot_maps(queries, 4, torch.float64), one_hot_maps(templates, 4, torch.float64), score,
                         reduction)
    fast = pairwise_scores(queries, templates, score, class_reduction=reduction)
    # Exact small-integer arithmetic: the float32 scores equal the float64 ones
    # up to float32 rounding of the final divisions and sums.
    torch.testing.assert_close(fast.double(), brute, rtol=1e-6, atol=1e-7)
    result = match_ground_truth(queries, templates, score, query_chunk=3, class_reduction=reduction)
    assert result.index.tolist() == _first_argmin(brute).tolist()
    assert result.index[3] == 5  # the tie goes to the lower index
    torch.testing.assert_close(result.score.double(), brute.min(1).values, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("score", ["mse", "top_mse"])
def test_soft_maps_equal_brute_force(score):
    g = torch.Generator().manual_seed(7)
    queries = torch.rand(5, 4, 18, 30, generator=g, dtype=torch.float64).softmax(1)
    templates = torch.rand(9, 4, 18, 30, generator=g, dtype=torch.float64).softmax(1)
    templates[4] = queries[1]
    brute = _brute_force(queries, templates, score)
    torch.testing.assert_close(pairwise_scores(queries, templates, score), brute, rtol=1e-9, atol=1e-12)
    result = match_ground_truth(queries, templates, score, query_chunk=2)
    assert result.index.tolist() == _first_argmin(brute).tolist()
    assert result.index[1] == 4


def test_three_classes_use_one_hot_code():
    queries, templates = _class_id_sets(5, (12, 20), num_classes=3)
    brute = _brute_force(one_hot_maps(queries, 3, torch.float64), one_hot_maps(templates, 3, torch.float64), "top_mse")
    fast = pairwise_scores(queries, templates, "top_mse", num_classes=3)
    torch.testing.assert_close(fast.double(), brute, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("num_classes", [2, 3, 4, 8])
def test_class_code_preserves_one_hot_distances(num_classes):
    code, factor = class_code(num_classes)
    onehot = torch.eye(num_classes)
    assert torch.equal(torch.cdist(code, code).square().round() * factor, torch.cdist(onehot, onehot).square().round())
    if num_classes in (2, 4, 8):
        assert code.shape == (num_classes, num_classes - 1)


def test_matmul_precision_restored():
    before = torch.get_float32_matmul_precision()
    queries, templates = _class_id_sets(1, (8, 8))
    match_ground_truth(queries, templates)
    assert torch.get_float32_matmul_precision() == before


def test_rejects_mixed_inputs():
    ids = torch.zeros(2, 8, 8, dtype=torch.long)
    with pytest.raises(ValueError):
        match_ground_truth(ids, one_hot_maps(ids))
    with pytest.raises(ValueError):
        match_ground_truth(ids, ids, "dice")


@pytest.mark.parametrize("score", ["mse", "top_mse"])
@pytest.mark.parametrize("reduction", ["sum", "mean"])
def test_matching_in_template_chunks_equals_one_block(score, reduction):
    """Chunked ground-truth matching (a large dictionary) gives the unchunked indices and scores,
    ties included: duplicated templates in different chunks keep the first."""
    generator = torch.Generator().manual_seed(3)
    queries = torch.randint(0, 4, (11, 12, 16), generator=generator)
    templates = torch.randint(0, 4, (23, 12, 16), generator=generator)
    templates[17] = templates[2]  # a tie across chunks
    templates[9] = queries[4]
    templates[20] = queries[4]  # the same best twice: the lower index wins
    whole = match_ground_truth(queries, templates, score, class_reduction=reduction)
    for chunk in (1, 4, 7, 22):
        part = match_ground_truth(queries, templates, score, template_chunk=chunk, class_reduction=reduction)
        assert part.index.tolist() == whole.index.tolist()
        # The squared errors are exact; Top-MSE's float combination may round 1 ulp apart by layout.
        torch.testing.assert_close(part.score, whole.score, rtol=1e-6, atol=0)
    assert whole.index[4] == 9
    # By hand: merging blocks in order is the same.
    merged = None
    for start in range(0, 23, 5):
        merged = merge_matches(merged, match_ground_truth(queries, templates[start:start + 5], score,
                                                          class_reduction=reduction), start)
    assert merged is not None and merged.index.tolist() == whole.index.tolist()
    # And the brute-force minimum of the pairwise scores.
    assert whole.index.tolist() == pairwise_scores(queries, templates, score, class_reduction=reduction
                                                   ).argmin(1).tolist()
