"""Reference controllers, addressable on the command line as `ref:NAME`."""

REFERENCE: dict[str, str] = {
    "idle": "robots.controllers.idle:Idle",
    "sensorless": "robots.controllers.sensorless:Sensorless",
    "dead-reckoning": "robots.controllers.dead_reckoning:DeadReckoning",
    "starter": "robots.controllers.starter:Starter",
    "tutorial": "robots.controllers.tutorial:MyBot",
    "best": "robots.controllers.best:Best",
    "bac": "robots.controllers.bac:Bac",
    "bac-seed": "robots.controllers.bac:BacSeed",
    "vannoy": "robots.controllers.vannoy:Vannoy",
    "ubersetzig": "robots.controllers.ubersetzig:Ubersetzig",
    "simi": "robots.controllers.simi:Simi",
    "osentoski": "robots.controllers.osentoski:Osentoski",
}
