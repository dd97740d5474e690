# Writes the recordings the interoperability test reads (cmake -P; WRITER, SIM, OUT defined).
# SIM is fuse-sim's path when that tool is built, empty otherwise.
foreach(compression zstd lz4 none)
  execute_process(COMMAND ${WRITER} ${OUT}/rec_${compression}.mcap ${compression} COMMAND_ERROR_IS_FATAL ANY)
endforeach()
if(SIM)
  file(REMOVE_RECURSE ${OUT}/sim)
  execute_process(COMMAND ${SIM} --scenario corridor --seed 1 --duration 4 --out ${OUT}/sim COMMAND_ERROR_IS_FATAL ANY)
  if(NOT EXISTS ${OUT}/sim/recording.mcap)
    message(FATAL_ERROR "fuse-sim did not write ${OUT}/sim/recording.mcap")
  endif()
endif()
