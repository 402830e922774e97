"""Writes the seeds of the `dicom` fuzz target: one small CT slice per transfer syntax and pixel
format the reader decodes (uncompressed implicit and explicit VR, deflated, 16-bit RLE; 8, 12
and 16 bits; signed and unsigned; with and without a rescale). Run with the test venv's Python
(pydicom): `.venv/bin/python fuzz/seeds/dicom/make_seeds.py`; the files are checked in.
"""

from pathlib import Path

import numpy as np
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import (
    CTImageStorage,
    DeflatedExplicitVRLittleEndian,
    ExplicitVRLittleEndian,
    ImplicitVRLittleEndian,
    RLELossless,
)

HERE = Path(__file__).parent


def write(name, syntax, bits_allocated, bits_stored, signed, rescale):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CTImageStorage
    meta.MediaStorageSOPInstanceUID = "1.2.826.0.1.3680043.8.498.10"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian if syntax == RLELossless else syntax
    d = FileDataset(name, {}, file_meta=meta, preamble=b"\0" * 128)
    d.SOPClassUID = CTImageStorage
    d.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    d.SeriesInstanceUID = "1.2.826.0.1.3680043.8.498.11"
    d.Modality = "CT"
    d.ImagePositionPatient = ["-12.5", "7.25", "3"]
    d.ImageOrientationPatient = ["1", "0", "0", "0", "1", "0"]
    d.PixelSpacing = ["0.8", "0.7"]
    d.SliceThickness = "1.25"
    d.Rows, d.Columns = 5, 6
    d.SamplesPerPixel = 1
    d.PhotometricInterpretation = "MONOCHROME2"
    d.BitsAllocated = bits_allocated
    d.BitsStored = bits_stored
    d.HighBit = bits_stored - 1
    d.PixelRepresentation = int(signed)
    if rescale:
        d.RescaleIntercept, d.RescaleSlope = rescale
    dtype = {(8, False): np.uint8, (16, False): np.uint16, (16, True): np.int16}[
        bits_allocated, signed
    ]
    top = (1 << (bits_stored - 1)) - 1 if signed else (1 << bits_stored) - 1
    pixels = np.linspace(-top if signed else 0, top, 30).astype(dtype).reshape(5, 6)
    if syntax == RLELossless:
        d.compress(RLELossless, pixels)
    else:
        d.PixelData = pixels.tobytes()
    d.save_as(HERE / name, enforce_file_format=True)


write("explicit-int16-hu.dcm", ExplicitVRLittleEndian, 16, 16, True, ("-1024", "1"))
write("implicit-uint12.dcm", ImplicitVRLittleEndian, 16, 12, False, None)
write("deflated-uint8.dcm", DeflatedExplicitVRLittleEndian, 8, 8, False, ("0", "0.5"))
write("rle-int16.dcm", RLELossless, 16, 16, True, None)
