"""Undoing the suspension's creep (``model.collision.CreepInverse``) on a reading the twin's
standard linear solid (``twin.nuisances``) crept."""

import numpy as np
import pytest

from whiskercal.model.collision import CreepInverse
from whiskercal.model.errors import ModelError
from whiskercal.twin.nuisances import Nuisances, SensorNuisances, ViscoelasticTable


def test_the_inverse_recovers_the_elastic_reading_of_a_linear_creep():
    rate, share, tau = 300.0, 0.05, 3.0
    creeping = SensorNuisances(Nuisances(viscoelastic=ViscoelasticTable(creep_share=share,
                                                                        tau_s=tau)), seed=0)
    inverse = CreepInverse(share, tau, rate, axes=1)
    rng = np.random.default_rng(3)
    elastic = np.concatenate([np.zeros(300), np.linspace(0, -3000, 600), np.full(1800, -3000.0),
                              np.linspace(-3000, 0, 300), np.zeros(900)])
    elastic = elastic + rng.normal(0, 5.6, elastic.size)
    crept = np.array([value + creeping.creep(value, 1 / rate) for value in elastic])
    assert np.max(np.abs(crept - elastic)) > 100.0  # 5 % of 3000 µT, after seconds
    recovered = np.array([inverse.update([value])[0] for value in crept])
    np.testing.assert_allclose(recovered, elastic, atol=1e-6)


def test_a_creep_out_of_range_is_refused():
    with pytest.raises(ModelError, match="share"):
        CreepInverse(1.5, 3.0, 300.0)
    with pytest.raises(ModelError, match="share"):
        CreepInverse(0.05, 0.0, 300.0)
