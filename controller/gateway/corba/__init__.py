"""CORBA transport (issue 11): the original IDL interfaces and the OpenRTM RT component."""
