# Sanitizer builds: -DDURER_SANITIZE=address,undefined (any list -fsanitize= takes) instruments the
# targets durer_sanitize() is called on. Undefined behaviour aborts (-fno-sanitize-recover) instead
# of printing and going on, so a fuzz run stops at the first report. bench/fuzz_sanitized.sh builds
# the Python module this way and runs the traversal fuzz under it (docs/reliability.md).
set(DURER_SANITIZE "" CACHE STRING "Sanitizers to build with, e.g. address,undefined (empty: none)")

function(durer_sanitize target)
  if(NOT DURER_SANITIZE)
    return()
  endif()
  set(flags -fsanitize=${DURER_SANITIZE} -fno-omit-frame-pointer)
  if(DURER_SANITIZE MATCHES "undefined")
    list(APPEND flags -fno-sanitize-recover=undefined)
  endif()
  target_compile_options(${target} PRIVATE ${flags} -g)
  # A static library passes the runtime on to whatever links it; a module or program links it.
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "STATIC_LIBRARY")
    target_link_options(${target} INTERFACE -fsanitize=${DURER_SANITIZE})
  else()
    target_link_options(${target} PRIVATE -fsanitize=${DURER_SANITIZE})
  endif()
endfunction()
