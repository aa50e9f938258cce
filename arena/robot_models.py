"""Built-in robot models a level names with `model:`."""

from arena.level import RobotModel

ROBOT_MODELS: dict[str, RobotModel] = {
    # Parallax BOE-bot as in Bac et al. 2011: 105 x 95 mm, peak 0.14-0.17 m/s.
    "boe-bot": RobotModel(
        name="boe-bot", length=0.105, width=0.095, mass=0.65, track=0.105,
        max_wheel_speed=0.17, max_wheel_accel=0.5, friction=0.7,
        silhouette_radius=0.02,  # the laser transmitter on its mast (ours: the seed gives no size)
    ),
    # A generic hobby robot of the size Vannoy and Ubersetzig describe (a laser turret on a small base).
    "generic": RobotModel(
        name="generic", length=0.30, width=0.25, mass=3.0, track=0.22,
        max_wheel_speed=0.5, max_wheel_accel=1.0, friction=0.7,
        silhouette_radius=0.05,  # a laser turret (ours)
    ),
    # A LEGO Technic MinDART robot as in Osentoski (size estimated from the schematic).
    "mindart": RobotModel(
        name="mindart", length=0.25, width=0.20, mass=1.2, track=0.16,
        max_wheel_speed=0.25, max_wheel_accel=0.8, friction=0.6,
        silhouette_radius=0.04,  # the photoresistor turret (ours)
    ),
}
