#!/bin/bash
# Every reader on the regression files and on 2000 mutations of small valid files of its
# format (made by make_files.sh in $1), ours and the crate's on the same inputs.
set -euo pipefail
dir=${1:-/tmp/io_crates_files}
run=${IO_CRATES:-$(dirname "$0")/target/release/io_crates}
cases=2001
for file in /work/shared/regressions/*.nii.gz; do
    for reader in ours-nifti nifti; do "$run" fuzz $reader "$file" 1; done
done
pairs=(
    "ours-nifti nifti small/s.nii small/s.nii.gz"
    "ours-stl stl_io small/vtk-ascii.stl small/vtk-binary.stl"
    "ours-ply ply-rs-bw small/vtk-ascii.ply small/vtk-binary.ply small/ours.ply"
    "ours-vtk-mesh vtkio small/vtk-ascii.vtk small/vtk-binary.vtk small/ours.vtk"
    "ours-vtk-image vtkio small/vtk-image-ascii.vtk small/vtk-image-binary.vtk"
    "ours-vtp vtkio small/vtk-ascii.vtp small/vtk-binary.vtp small/vtk-appended.vtp small/ours.vtp"
    "ours-vti vtkio small/vtk-image-ascii.vti small/vtk-image-binary.vti small/vtk-image-appended.vti"
)
for line in "${pairs[@]}"; do
    read -r ours theirs files <<<"$line"
    for file in $files; do
        for reader in "$ours" "$theirs"; do "$run" fuzz "$reader" "$dir/$file" $cases; done
    done
done
