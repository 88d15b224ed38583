from gdabench import Body
from gdabench.testing import check_designer, check_environment

from gdabench_checkerboard.designer import HillClimber
from gdabench_checkerboard.environment import Checkerboard


def test_designer_conforms():
    check_designer(HillClimber, params={"rate": 0.2})


def test_environment_conforms():
    check_environment(Checkerboard)


def test_a_checkerboard_scores_the_optimum():
    env = Checkerboard(shape=(5, 5))
    assert env.evaluate(Body.from_text("34343/43434/34343/43434/34343"), seed=0) == env.optimum
