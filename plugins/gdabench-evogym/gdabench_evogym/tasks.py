"""The task ids of Evolution Gym 2.0 (``evogym.BASELINE_ENV_NAMES``).

Kept here as data so that ``gdabench list`` does not import the simulator; a test checks the
list against the installed Evolution Gym.
"""

TASKS = (
    "Walker-v0", "BridgeWalker-v0", "BidirectionalWalker-v0", "Carrier-v0", "Carrier-v1", "Pusher-v0",
    "Pusher-v1", "Thrower-v0", "Catcher-v0", "BeamToppler-v0", "BeamSlider-v0", "Lifter-v0", "Climber-v0",
    "Climber-v1", "Climber-v2", "UpStepper-v0", "DownStepper-v0", "ObstacleTraverser-v0",
    "ObstacleTraverser-v1", "Hurdler-v0", "PlatformJumper-v0", "GapJumper-v0", "Traverser-v0",
    "CaveCrawler-v0", "AreaMaximizer-v0", "AreaMinimizer-v0", "WingspanMazimizer-v0", "HeightMaximizer-v0",
    "Flipper-v0", "Jumper-v0", "Balancer-v0", "Balancer-v1",
)  # fmt: skip
