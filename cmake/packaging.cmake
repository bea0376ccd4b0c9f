# Installation, the Debian package and their tests (docs/install.md), and the tests of the
# Python interop (docs/python.md). Included from the top-level CMakeLists.txt.

# `cmake --install build --prefix P`. Paths are literal, not GNUInstallDirs', because
# find_default_model() (src/core/model/default_model.cpp) looks for the model at
# <exe dir>/../share/spikems/models/: bin/ and share/ must stay siblings.
install(TARGETS spikems RUNTIME DESTINATION bin)
# The LibTorch commands' program (src/cli/torch_helper.h): found at <exe dir>/../lib/spikems/.
if(TARGET spikems-torch)
  install(TARGETS spikems-torch RUNTIME DESTINATION lib/spikems)
endif()
install(FILES models/spikems-default.safetensors models/spikems-fast.safetensors models/README.md
        DESTINATION share/spikems/models)
# The simulator's presets are compiled into the binary (configs/sim/*.toml →
# generated/sim_presets.inc), so there is nothing to install for them.
install(FILES README.md LICENSE DESTINATION share/doc/spikems)
install(DIRECTORY docs/ DESTINATION share/doc/spikems/docs)

# The .deb: `scripts/package` (cpack -G DEB in a Release build).
set(SPIKEMS_MAINTAINER "spikems maintainers <maintainers@users.noreply.h-seed-2211f08e.example>"
    CACHE STRING "Maintainer field of the Debian package")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME spikems)
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "motion segmentation of event-camera streams with a spiking neural network")
string(CONCAT CPACK_PACKAGE_DESCRIPTION
       "spikems reads and writes event-camera recordings (Prophesee, iniVation, research "
       "formats), simulates labelled event data, and segments moving objects with the SpikeMS "
       "spiking network. Ships a small experimental model (/usr/share/spikems/models/README.md).")
set(CPACK_RESOURCE_FILE_LICENSE "${CMAKE_SOURCE_DIR}/LICENSE")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # spikems_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${SPIKEMS_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
# Depends: from the libraries the binary links (dpkg-shlibdeps, from dpkg-dev).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_STRIP_FILES ON)
include(CPack)

if(SPIKEMS_BUILD_TESTS)
  # Debian's interpreter, which has python3-numpy and python3-h5py (scripts/setup); `python3` on
  # PATH may be a pyenv shim without them.
  set(SPIKEMS_PYTHON /usr/bin/python3 CACHE FILEPATH "Python with numpy and h5py for the tests")
  # Prints a model file's tensors as JSON, as spikems loads them (tests/python/).
  add_executable(spikems_dump_model "${CMAKE_SOURCE_DIR}/tests/python/dump_model.cpp")
  target_link_libraries(spikems_dump_model PRIVATE spikems_model)
  foreach(t h5_layout safetensors npz)
    add_test(NAME python_${t}
             COMMAND ${SPIKEMS_PYTHON} "${CMAKE_SOURCE_DIR}/tests/python/test_${t}.py"
                     --spikems "$<TARGET_FILE:spikems>"
                     --dump-model "$<TARGET_FILE:spikems_dump_model>"
                     --source "${CMAKE_SOURCE_DIR}")
    # Exit 77 = skipped (numpy or h5py missing; the test prints which).
    set_tests_properties(python_${t} PROPERTIES LABELS python SKIP_RETURN_CODE 77 TIMEOUT 600)
  endforeach()

  # Installs into a temporary prefix and runs the installed spikems (about a second).
  add_test(NAME install_tree COMMAND "${CMAKE_SOURCE_DIR}/tests/package/test_install.sh"
                                     "${CMAKE_BINARY_DIR}")
  set_tests_properties(install_tree PROPERTIES LABELS install TIMEOUT 300)

  # Packs the build dependencies, moves the folder and configures spikems from it (~10 s).
  add_test(NAME pack_build_deps COMMAND "${CMAKE_SOURCE_DIR}/tests/package/test_pack_build_deps.sh")
  set_tests_properties(pack_build_deps PROPERTIES LABELS install TIMEOUT 300)

  # scripts/build_pgo's binary labels a room as the plain one does (two builds of spikems,
  # ~10-20 min on 2 cores: "slow"; ctest --test-dir build -L pgo).
  add_test(NAME pgo_build COMMAND "${CMAKE_SOURCE_DIR}/tests/package/test_pgo.sh"
                                  "${CMAKE_BINARY_DIR}")
  set_tests_properties(pgo_build PROPERTIES LABELS "pgo;slow" TIMEOUT 3600)

  # Builds the .deb (a whole Release build the first time), so it is "slow" and left out of
  # the default run: ctest --test-dir build -L package.
  add_test(NAME package_deb
           COMMAND "${CMAKE_SOURCE_DIR}/tests/package/test_deb.sh"
                   "-DSPIKEMS_WITH_TRAIN=${SPIKEMS_WITH_TRAIN}")
  set_tests_properties(package_deb PROPERTIES LABELS "package;slow" TIMEOUT 3600)
  # The same for `scripts/package --pgo` in its own folder (two builds: ctest -L pgo).
  add_test(NAME package_deb_pgo
           COMMAND "${CMAKE_SOURCE_DIR}/tests/package/test_deb.sh" --pgo
                   "-DSPIKEMS_WITH_TRAIN=${SPIKEMS_WITH_TRAIN}")
  set_tests_properties(package_deb_pgo PROPERTIES LABELS "package;pgo;slow" TIMEOUT 5400
                       ENVIRONMENT "PACKAGE_BUILD_DIR=${CMAKE_BINARY_DIR}/package-pgo")
endif()
