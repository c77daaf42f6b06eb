# The fuzz targets replayed without libFuzzer (fuzz/replay.c) in every
# build: the regression inputs of past findings (data/fuzz/TARGET/) and the
# corpora scripts/fuzz-campaign.sh keeps (fuzz/corpus/TARGET/). A crash or
# a sanitizer report fails the test; the timeout is a backstop against work
# that explodes again (an input here once took minutes), not a speed test.
set(fuzz_dir ${PROJECT_SOURCE_DIR}/fuzz)
function(ch_add_replay target source libs)
  add_executable(replay_${target} ${fuzz_dir}/${source} ${fuzz_dir}/replay.c)
  target_link_libraries(replay_${target} PRIVATE ${libs})
  set(inputs)
  foreach(dir ${CHISEL_TEST_DATA}/fuzz/${target} ${fuzz_dir}/corpus/${target})
    if(EXISTS ${dir})
      list(APPEND inputs ${dir})
    endif()
  endforeach()
  if(inputs)
    add_test(NAME replay_${target} COMMAND replay_${target} ${inputs})
    set_tests_properties(replay_${target} PROPERTIES TIMEOUT 300)
  endif()
endfunction()
ch_add_replay(fuzz_svg fuzz_svg.c chisel_shade)
ch_add_replay(fuzz_exr fuzz_exr.c chisel_core)
ch_add_replay(fuzz_dci fuzz_dci.c chisel_shade)
ch_add_replay(fuzz_featmap fuzz_featmap.c chisel_shade)
ch_add_replay(fuzz_scene fuzz_scene.c chisel_validate)
foreach(format obj ply off stl glb gltf)
  ch_add_replay(fuzz_mesh_${format} fuzz_mesh.c chisel_mesh)
  target_compile_definitions(replay_fuzz_mesh_${format} PRIVATE CHISEL_FUZZ_FORMAT="${format}")
endforeach()
# The OBJ target also holds our reader to OpenMesh's: on the test meshes and
# the bundled models too.
file(GLOB obj_meshes ${CHISEL_TEST_DATA}/mesh/*.obj ${PROJECT_SOURCE_DIR}/models/*.obj)
add_test(NAME replay_fuzz_mesh_obj_models COMMAND replay_fuzz_mesh_obj ${obj_meshes})
