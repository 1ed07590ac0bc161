"""Active contour following: the paper's closed loop as a library (docs/contour.md)."""

from whiskercal.follow.config import FollowConfig, load_follow_config
from whiskercal.follow.controller import Follower, Robot, Step
from whiskercal.follow.phases import RULES, Phase, Transition
from whiskercal.follow.predictor import predict_next, surface_step

__all__ = ["RULES", "FollowConfig", "Follower", "Phase", "Robot", "Step", "Transition",
           "load_follow_config", "predict_next", "surface_step"]
