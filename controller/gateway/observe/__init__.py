"""What the gateway shows besides gRPC: the live view (Foxglove protocol) and the black box."""
