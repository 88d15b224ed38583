"""The plugin's own tests: gdabench's conformance checks plus MAP-Elites behaviour."""

import pytest
from gdabench_mapelites import MapElites

from gdabench import ConfigError, make_designer
from gdabench.body import Body
from gdabench.testing import check_designer


def test_conforms_to_the_designer_contract():
    check_designer(MapElites)
    check_designer(MapElites, params={"bins": 2})


def test_registered_through_its_entry_point():
    assert isinstance(make_designer("map-elites", population=5, budget=50), MapElites)


def test_archive_keeps_the_best_body_per_cell_and_fills_many_cells():
    me = MapElites(population=25, budget=500, seed=0)
    for _ in range(20):
        bodies = me.ask()
        me.tell(bodies, [float(b.voxels.sum()) for b in bodies])
    assert len(me.archive) >= 10  # diversity: many (size, muscle) niches occupied
    for cell, (body, reward) in me.archive.items():
        assert me.cell(body) == cell and reward == body.voxels.sum()


def test_cells():
    me = MapElites(population=5, budget=50, bins=5)
    assert me.cell(Body.from_text("44444/44444/44444/44444/44444")) == (4, 4)
    assert me.cell(Body.from_text("30000/00000/00000/00000/00000")) == (0, 4)
    assert me.cell(Body.from_text("31111/11111/11111/11111/11111")) == (4, 0)


def test_bad_bins():
    with pytest.raises(ConfigError, match="bins must be at least 1"):
        MapElites(bins=0)
