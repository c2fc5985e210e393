"""What the tests of the track world drive with: the donkeycar's car (`DONKEY`), the same car with only its
first-order throttle model (`IDEAL`), and a pilot of fixed controls that counts its resets (`Scripted`)."""

from dataclasses import replace

from steerlab.data.car import CARS
from steerlab.data.recording import SteeringConvention
from steerlab.pilot import Controls

DONKEY = CARS["donkey"]
IDEAL = replace(DONKEY, drag=0.0, motor=replace(DONKEY.motor, rolling=0.0))  # the first-order throttle model alone


class Scripted:
    """A pilot with a fixed road-wheel angle (rad, positive left) and throttle (None: gives none) that counts
    its resets."""

    name, geometry, source = "scripted", "donkey", "scripted"
    convention = SteeringConvention("road_wheel", "left")

    def __init__(self, road_wheel=0.0, throttle=None):
        self.road_wheel, self.throttle, self.resets = road_wheel, throttle, 0

    def step(self, frame, speed=None):
        return Controls(self.road_wheel, throttle=self.throttle)

    def reset(self):
        self.resets += 1
