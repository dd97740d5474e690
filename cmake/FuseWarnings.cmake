# Strict warnings for the project's own code. Generated code (fastddsgen, idlc, protoc) and
# third-party headers (included as SYSTEM) are exempt: they get no fuse_warnings.
# FUSE_WERROR=OFF keeps the warnings but does not fail on them: for distribution builds
# (debian/rules), whose flags (-O2, _FORTIFY_SOURCE) and compilers may warn where ours do not.
option(FUSE_WERROR "treat warnings in the project's own code as errors" ON)
add_library(fuse_warnings INTERFACE)
target_compile_options(fuse_warnings INTERFACE -Wall -Wextra)
if(FUSE_WERROR)
  target_compile_options(fuse_warnings INTERFACE -Werror)
endif()

# fuse_target(<target>): applies the project's warning policy to one of its own targets.
function(fuse_target target)
  target_link_libraries(${target} PRIVATE fuse_warnings)
endfunction()
