"""The original CORBA interfaces, served by the gateway beside gRPC (docs/corba.md).

Thin servants (``spec_a``, ``jara``, ``dual``) convert CORBA values to spec-unit Python
values and call the same services as the gRPC servicers (``controller.gateway.services``);
``server`` owns the ORB, the POA, the naming-service bindings and the IOR files. Importing
this package needs omniORBpy (the ``corba`` extra).
"""
