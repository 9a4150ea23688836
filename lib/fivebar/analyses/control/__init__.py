"""Control of the motors: the linear control model of the linkage with free rotors
(``control_model``), the servo and its design (``control_design``) and the closed loop over a
cycle (``control_simulation``)."""
