"""The simulated robot: a MuJoCo world (body, muscles, floor), an overhead camera and offline experiments.

No ROS imports: :mod:`srs_ros.sim.world` steps the physics for a node in real time or for an experiment
faster than real time; :mod:`srs_ros.sim.camera` renders what the overhead camera sees and
:mod:`srs_ros.sim.scene` draws synthetic camera frames from known poses; :mod:`srs_ros.sim.experiment` runs one
gait on the simulated robot and measures it like the paper's Table I; :mod:`srs_ros.sim.model` builds the MuJoCo
model, :mod:`srs_ros.sim.tether` its optional supply tubes and :mod:`srs_ros.sim.moment_limit` the optional limit
on the muscles' bending moment; :mod:`srs_ros.sim.config` reads config/sim.yaml; :mod:`srs_ros.sim.realtime`
paces the world to a clock and plays the regulators' board for the ``sim_world`` node;
:mod:`srs_ros.sim.navigation` drives the navigator's controller on the simulated robot offline, and
:mod:`srs_ros.sim.stop_oracle` the same with every stop's resting point known (a bound for studies, not a
controller).
"""
