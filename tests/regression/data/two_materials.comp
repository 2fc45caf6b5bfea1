# Tolerances of test_readers.py's comparison with our own earlier output: relative 1e-6, with
# floors about 1e-10 of each quantity's scale, so that components that are zero by symmetry
# (the Y ones, round-off around zero) compare by that scale and not by their own size. Every
# variable is listed: the comparator checks only those a section names once it names any.
COORDINATES absolute 1.e-12
TIME STEPS relative 1.e-12 floor 0.0
GLOBAL VARIABLES relative 1.e-6 floor 1.e-4
	Global_Kinetic_Energy relative 1.e-6 floor 1.e-7
	Right_ForceX relative 1.e-6 floor 1.e-4
	Right_ForceY relative 1.e-6 floor 1.e-4
	Right_ForceZ relative 1.e-6 floor 1.e-4
NODAL VARIABLES relative 1.e-6 floor 1.e-12
	DisplacementX relative 1.e-6 floor 1.e-12
	DisplacementY relative 1.e-6 floor 1.e-12
	DisplacementZ relative 1.e-6 floor 1.e-12
	VelocityX relative 1.e-6 floor 1.e-9
	VelocityY relative 1.e-6 floor 1.e-9
	VelocityZ relative 1.e-6 floor 1.e-9
	ForceX relative 1.e-6 floor 1.e-5
	ForceY relative 1.e-6 floor 1.e-5
	ForceZ relative 1.e-6 floor 1.e-5
	AccelerationX relative 1.e-6 floor 1.e-5
	AccelerationY relative 1.e-6 floor 1.e-5
	AccelerationZ relative 1.e-6 floor 1.e-5
ELEMENT VARIABLES relative 1.e-6 floor 1.e-12
