# CTest script (cmake -P): fails when any source, net, script or test of the repository refers to
# files outside the clone (the reference folder `shared/` beside our own checkouts does not exist
# in a user's clone). Run with -DROOT=<source dir>.
if(NOT ROOT)
  message(FATAL_ERROR "usage: cmake -DROOT=<source dir> -P SelfContained.cmake")
endif()
file(GLOB_RECURSE files
  ${ROOT}/Algorithms/* ${ROOT}/Dataflow/* ${ROOT}/Modules/* ${ROOT}/Interface/*
  ${ROOT}/Testing/*.cpp ${ROOT}/Testing/*.h ${ROOT}/Testing/*.txt ${ROOT}/Testing/*.srn
  ${ROOT}/Nets/* ${ROOT}/scripts/* ${ROOT}/.ci/* ${ROOT}/CMakeLists.txt)
set(bad "")
set(count 0)
foreach(f ${files})
  if(f MATCHES "\\.(png|nrrd|gz)$")
    continue()
  endif()
  math(EXPR count "${count} + 1")
  file(STRINGS ${f} hits REGEX "\\.\\./shared|shared/(data|reference|seed|notes)|/work/")
  if(hits)
    list(APPEND bad "${f}: ${hits}")
  endif()
endforeach()
if(count LESS 50)
  message(FATAL_ERROR "only ${count} files scanned under ${ROOT}: wrong ROOT?")
endif()
if(bad)
  string(REPLACE ";" "\n  " text "${bad}")
  message(FATAL_ERROR "files that read outside the repository:\n  ${text}")
endif()
message(STATUS "${count} files scanned, none refers outside the repository")
