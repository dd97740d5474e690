# Strict warnings for the project's own code. Generated code (fastddsgen, idlc, protoc) and
# third-party headers (included as SYSTEM) are exempt: they get no fuse_warnings.
add_library(fuse_warnings INTERFACE)
target_compile_options(fuse_warnings INTERFACE -Wall -Wextra -Werror)

# fuse_target(<target>): applies the project's warning policy to one of its own targets.
function(fuse_target target)
  target_link_libraries(${target} PRIVATE fuse_warnings)
endfunction()
