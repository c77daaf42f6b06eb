# Bundled models (models/): the committed OBJ and SVG files must be exactly
# what models/generate.py writes. models_up_to_date regenerates them into a
# scratch folder and diffs every generated file against its committed copy,
# so a hand edit, or a generator change committed without regenerating,
# fails here. Fix with: python3 models/generate.py models
# models_check runs the generator's own sanity checks on the committed files
# (UV charts not flipped and not overlapping, UVs in [0,1], closed meshes
# watertight and outward, every SVG shape with a data-kind, inside viewBox).
find_program(CHISEL_PYTHON3 NAMES python3)
if(CHISEL_PYTHON3)
  add_test(NAME models_up_to_date
    COMMAND sh -c [=[
py=$1 src=$2 out=$3
rm -rf "$out" || exit 1
"$py" "$src/models/generate.py" "$out" || exit 1
cd "$out" || exit 1
status=0
for f in $(find . -type f | LC_ALL=C sort); do
  f=${f#./}
  if ! diff -u "$src/models/$f" "$f" > diff.tmp 2>&1; then
    echo "models/$f is not what models/generate.py writes:"
    head -n 40 diff.tmp
    status=1
  fi
done
rm -f diff.tmp
[ $status -eq 0 ] || echo "regenerate with: python3 models/generate.py models"
exit $status
]=] models_up_to_date ${CHISEL_PYTHON3} ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_BINARY_DIR}/models_generated)
  add_test(NAME models_check
    COMMAND ${CHISEL_PYTHON3} ${PROJECT_SOURCE_DIR}/models/generate.py --check ${PROJECT_SOURCE_DIR}/models)
else()
  message(STATUS "python3 not found: models_up_to_date and models_check are not run")
endif()
