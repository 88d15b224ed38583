"""The catalog of Evolution Gym 2.0's 32 tasks: ids, grades, step limits, where each is defined.

Plain data, so that listing tasks and registering their Gymnasium ids loads no numerics.  Grades are
Evolution Gym's own (its site's task pages, EvolutionGym/evolutiongym.github.io, ``docs/all-tasks``);
step limits are those ``evogym/envs/__init__.py`` registers.
"""

from __future__ import annotations

from typing import NamedTuple


class Entry(NamedTuple):
    id: str
    difficulty: str  # easy, medium or hard
    max_episode_steps: int
    module: str  # the module of gdabench.envs.tasks that defines it (after Evolution Gym's file)
    summary: str


#: in ``evogym.BASELINE_ENV_NAMES`` order
ENTRIES = (
    Entry("Walker-v0", "easy", 500, "walking", "walk as far as possible on flat terrain"),
    Entry("BridgeWalker-v0", "easy", 500, "walking", "walk as far as possible on a soft rope bridge"),
    Entry("BidirectionalWalker-v0", "medium", 1000, "goals", "walk to goals that switch between left and right"),
    Entry("Carrier-v0", "easy", 500, "manipulation", "carry a box on top as far as possible"),
    Entry("Carrier-v1", "hard", 1000, "manipulation", "carry a box to a table and put it on the table"),
    Entry("Pusher-v0", "easy", 500, "manipulation", "push a box in front of the robot"),
    Entry("Pusher-v1", "medium", 600, "manipulation", "push or drag forwards a box starting behind the robot"),
    Entry("Thrower-v0", "medium", 300, "manipulation", "throw a box that starts on top of the robot"),
    Entry("Catcher-v0", "hard", 400, "manipulation", "catch a fast, spinning box"),
    Entry("BeamToppler-v0", "easy", 1000, "manipulation", "knock a beam off two pegs from underneath"),
    Entry("BeamSlider-v0", "hard", 1000, "manipulation", "slide a beam along a line of pegs from underneath"),
    Entry("Lifter-v0", "hard", 300, "manipulation", "lift a box out of a hole"),
    Entry("Climber-v0", "medium", 400, "climbing", "climb a flat vertical channel"),
    Entry("Climber-v1", "medium", 600, "climbing", "climb a channel of rigid and soft walls"),
    Entry("Climber-v2", "hard", 1000, "climbing", "climb a narrow stepwise channel"),
    Entry("UpStepper-v0", "medium", 600, "locomotion", "climb up stairs of varying lengths"),
    Entry("DownStepper-v0", "easy", 500, "locomotion", "climb down stairs of varying lengths"),
    Entry("ObstacleTraverser-v0", "medium", 1000, "locomotion", "walk across terrain that gets bumpier"),
    Entry("ObstacleTraverser-v1", "hard", 1000, "locomotion", "walk through very bumpy terrain"),
    Entry("Hurdler-v0", "hard", 1000, "locomotion", "walk across terrain with tall obstacles"),
    Entry("PlatformJumper-v0", "hard", 1000, "locomotion", "cross floating platforms at different heights"),
    Entry("GapJumper-v0", "hard", 1000, "locomotion", "cross spaced-out floating platforms of one height"),
    Entry("Traverser-v0", "hard", 600, "locomotion", "cross a pit of rigid blocks without sinking"),
    Entry("CaveCrawler-v0", "medium", 1000, "walking", "squeeze through caves and under low obstacles"),
    Entry("AreaMaximizer-v0", "easy", 600, "shape", "grow to cover the largest area"),
    Entry("AreaMinimizer-v0", "medium", 600, "shape", "shrink to cover the smallest area"),
    Entry("WingspanMazimizer-v0", "easy", 600, "shape", "grow as wide as possible"),
    Entry("HeightMaximizer-v0", "easy", 500, "shape", "grow as tall as possible"),
    Entry("Flipper-v0", "easy", 600, "misc", "flip counter-clockwise as often as possible"),
    Entry("Jumper-v0", "easy", 500, "misc", "jump as high as possible in place"),
    Entry("Balancer-v0", "easy", 600, "misc", "balance on a thin pole"),
    Entry("Balancer-v1", "medium", 600, "misc", "jump onto a thin pole and balance on it"),
)

CATALOG = {entry.id: entry for entry in ENTRIES}
