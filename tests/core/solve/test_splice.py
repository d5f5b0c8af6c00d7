"""Splicing a re-baked span into the old bake (pure core): outside the span and its
fades every key is the old one exactly (shifted after it by the span's change in
length); inside, the new keys, faded in and out."""

import numpy as np
from hypothesis import given, settings, strategies as st

from footstep_planner.core.solve.splice import SpanMap, splice_curve


@settings(max_examples=200, deadline=None)
@given(st.integers(-50, 50), st.integers(40, 200), st.integers(8, 25), st.integers(5, 60),
       st.integers(-20, 20), st.integers(0, 6), st.integers(0, 6), st.integers(0, 10), st.integers(0, 2 ** 31 - 1))
def test_outside_the_span_and_its_fades_every_key_is_the_old_one(first, n, fa_off, length, dlen, fin, fout,
                                                                   gshift, seed):
    rng = np.random.default_rng(seed)
    fa = first + fa_off
    fb = min(fa + length, first + n - 12)
    new_len = max(fb - fa + dlen, 2)
    ga = first + gshift
    old = rng.normal(size=n)
    new = rng.normal(size=ga - first + new_len + 30)
    end = fa + new_len
    span = SpanMap.fitted(fa, fb, ga, ga + new_len, (fa - fin, fa + 3), (end - 1, end + fout + 2))
    frames, vals = splice_curve(first, old, first, new, span)
    assert len(frames) == n + span.delta and frames[0] == first
    lo, hi = span.changed()
    before = frames < lo
    assert np.array_equal(vals[before], old[frames[before] - first])
    after = frames > hi
    assert np.array_equal(vals[after], old[frames[after] - span.delta - first])
    assert span.fade_in[1] <= span.fade_out[0]


def test_inside_the_span_the_new_keys_play_and_fade_in_and_out():
    old = np.zeros(100)
    new = np.ones(200)
    span = SpanMap.fitted(20, 50, 120, 170, (18, 24), (70, 76))  # the span grows from 30 to 50 frames
    frames, vals = splice_curve(0, old, 0, new, span)
    assert len(frames) == 120
    assert np.allclose(vals[(frames >= 24) & (frames <= 70)], 1.0)
    ramp_in = vals[(frames >= 18) & (frames <= 24)]
    assert np.all(np.diff(ramp_in) >= 0) and ramp_in[0] == 0.0
    ramp_out = vals[(frames >= 70) & (frames <= 76)]
    assert np.all(np.diff(ramp_out) <= 0) and ramp_out[-1] == 0.0
    assert np.all(vals[frames > 76] == 0.0) and np.all(vals[frames < 18] == 0.0)
