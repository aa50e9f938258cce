"""Built-in robot models a level names with `model:`; their drive errors are documented in docs/drive.md."""

from levels.model import DriveErrors, RobotModel

# Hobby servos or gear motors on small wheels, driven over a slow one-way radio link
# (Bac et al. 2011: commands every 200 ms at 4,800 baud). A level may override any of these per robot.
HOBBY_DRIVE = DriveErrors(
    gain_sd=0.01,
    radius_sd=0.01,
    track_sd=0.01,
    dead_band=0.03,
    saturation=0.3,
    turn_slip=0.03,
    turn_slip_sd=0.02,
    accel_slip=0.03,
    latency=0.015,
    latency_jitter=0.02,
)

ROBOT_MODELS: dict[str, RobotModel] = {
    # Parallax BOE-bot as in Bac et al. 2011: 105 x 95 mm, peak 0.14-0.17 m/s.
    "boe-bot": RobotModel(
        name="boe-bot",
        length=0.105,
        width=0.095,
        mass=0.65,
        track=0.105,
        max_wheel_speed=0.17,
        max_wheel_accel=0.5,
        friction=0.7,
        drive=HOBBY_DRIVE,
        silhouette_radius=0.02,  # the laser transmitter on its mast (ours: the seed gives no size)
    ),
    # A generic hobby robot of the size Vannoy and Ubersetzig describe (a laser turret on a small base).
    "generic": RobotModel(
        name="generic",
        length=0.30,
        width=0.25,
        mass=3.0,
        track=0.22,
        max_wheel_speed=0.5,
        max_wheel_accel=1.0,
        friction=0.7,
        drive=HOBBY_DRIVE,
        silhouette_radius=0.05,  # a laser turret (ours)
    ),
    # A LEGO Technic MinDART robot as in Osentoski (size estimated from the schematic).
    "mindart": RobotModel(
        name="mindart",
        length=0.25,
        width=0.20,
        mass=1.2,
        track=0.16,
        max_wheel_speed=0.25,
        max_wheel_accel=0.8,
        friction=0.6,
        drive=HOBBY_DRIVE,
        silhouette_radius=0.04,  # the photoresistor turret (ours)
    ),
}
