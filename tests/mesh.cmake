# Mesh tests: readers (through OpenMesh), validation, OBJ/PLY writers.
# Included from tests/CMakeLists.txt; inputs live in tests/data/mesh.
ch_add_test(NAME test_mesh SOURCES test_mesh.c LIBS chisel_mesh OpenMP::OpenMP_C)
# The glTF 2.0 reader (mesh/ch_mesh_gltf_read.c): files made in the test.
ch_add_test(NAME test_gltf SOURCES test_gltf.c LIBS chisel_mesh)
