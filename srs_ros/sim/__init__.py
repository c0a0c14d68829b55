"""The simulated robot: a MuJoCo world (body, muscles, floor), an overhead camera and offline experiments.

No ROS imports: :mod:`srs_ros.sim.world` steps the physics for a node in real time or for an experiment
faster than real time; :mod:`srs_ros.sim.camera` renders what the overhead camera sees;
:mod:`srs_ros.sim.experiment` runs one gait on the simulated robot and measures it like the paper's Table I;
:mod:`srs_ros.sim.model` builds the MuJoCo model, :mod:`srs_ros.sim.tether` its optional supply tubes.
"""
