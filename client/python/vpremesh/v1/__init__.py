# remesh_pb2.py and remesh_pb2_grpc.py land here when the package is built
# (setup.py generates them from proto/vpremesh/v1/remesh.proto).
