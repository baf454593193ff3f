"""CANopen joint drives (CiA 301 communication, CiA 402 drive profile) as a pliant driver, and a peer to test it.

``pliant_canopen.driver``: :class:`~pliant_canopen.driver.CanopenDriver`, the transport of an arm built from CiA 402
servo drives in cyclic synchronous position mode.  ``pliant_canopen.jointmap``: the joint-map file (which node
drives which URDF joint, encoder scaling) and the object dictionary (EDS) checks.  ``pliant_canopen.testing``: CiA
402 drives emulated on a python-can bus, with fault injection (for tests and demos).  ``pliant_canopen.cia402``: the
profile's constants.
"""
