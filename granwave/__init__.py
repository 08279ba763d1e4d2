"""granwave: computational granular acoustics.

Units throughout (SPEC §1): mean grain diameter = 1, grain density = 1,
modified Young modulus E* = E/(1-nu^2) = 1; time then follows so that the
longitudinal sound speed of the grain material is 1.
"""

__version__ = "0.1.0"
