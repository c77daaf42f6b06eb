# Mesh tests: readers (through OpenMesh), validation, OBJ/PLY writers.
# Included from tests/CMakeLists.txt; inputs live in tests/data/mesh.
ch_add_test(NAME test_mesh SOURCES test_mesh.c LIBS chisel_mesh)
