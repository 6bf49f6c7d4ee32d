"""Robot descriptions: YAML -> frozen, validated dataclasses."""
from .loader import load_robot, robot_from_text
from .robot import Actuator, Body, Controller, Coordinate, Joint, Robot, Simulation, Trajectory

__all__ = ["load_robot", "robot_from_text", "Robot", "Body", "Joint", "Coordinate",
           "Actuator", "Controller", "Trajectory", "Simulation"]
