"""Active contour following: the paper's closed loop as a library (docs/contour.md)."""

from whiskercal.follow.config import FollowConfig, load_follow_config
from whiskercal.follow.controller import Follower, Robot, Step
from whiskercal.follow.predictor import predict_next, surface_step

__all__ = ["FollowConfig", "Follower", "Robot", "Step", "load_follow_config", "predict_next",
           "surface_step"]
