# Fix-ups for building against the ROS 2 wheels from PyPI (no effect on a system ROS install),
# shared by every package of interfaces/: each one's CMakeLists.txt includes it from ../cmake/
# (its real path, so a package symlinked into a workspace finds it). A package copied out on its
# own builds without it: fine on a system ROS 2, where nothing needs repairing; against the wheels,
# build it in place (scripts/build-interfaces.sh, scripts/colcon-build.sh) or symlink it.
#
# The wheels' exported *__rosidl_generator_py targets carry include directories of the
# machine they were built on (/opt/python/cp3XX-...). CMake refuses imported targets with
# missing include paths, so drop every non-existent path from the imported targets of this
# directory and add this interpreter's Python and NumPy headers instead.
get_property(_imported_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_target IN LISTS _imported_targets)
  get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT _dirs)
    continue()
  endif()
  set(_kept "")
  set(_dropped FALSE)
  foreach(_dir IN LISTS _dirs)
    if(_dir MATCHES "^\\$<" OR EXISTS "${_dir}")
      list(APPEND _kept "${_dir}")
    else()
      set(_dropped TRUE)
    endif()
  endforeach()
  if(_dropped)
    list(APPEND _kept ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    list(REMOVE_DUPLICATES _kept)
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
    message(STATUS "pypi-ros fix-up: repaired include dirs of ${_target}")
  endif()
endforeach()
