"""Default calibration tolerances of a measurement chain between captures (no imports: a
command's ``--help`` reads them without loading the engine).

Sources and use: :mod:`eddi.diagnosis.tolerance` (module notes).
"""

#: Default relative difference of the accelerometer's sensitivity between captures (1 %:
#: ISO 16063-21 back-to-back comparison calibration, a certificate's typical expanded uncertainty).
GAIN_TOLERANCE = 0.01
#: Default sample-clock difference between captures [ppm] (a DAQ timebase's accuracy).
CLOCK_PPM = 50.0
