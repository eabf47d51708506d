# The public API of hdrfringe: what `import hdrfringe as hf` offers, loaded on first use.
# This stub is the single list: hdrfringe/__init__.py hands it to lazy_loader.attach_stub, and
# type checkers read it. Every name below must be importable (tests/test_api.py).

from .calibration import Calibration as Calibration
from .captures import CameraSettings as CameraSettings
from .captures import Captures as Captures
from .captures import FringeSet as FringeSet
from .captures import ProjectorInfo as ProjectorInfo
from .errors import CaptureFormatError as CaptureFormatError
from .errors import HdrFringeError as HdrFringeError
from .errors import InputError as InputError
from .errors import OutputExistsError as OutputExistsError
from .frames import CenterlineFrame as CenterlineFrame
from .frames import FringeFrame as FringeFrame
from .frames import ImageFrame as ImageFrame
from .frames import PixelwiseFringeFrame as PixelwiseFringeFrame
from .frames import UniformFrame as UniformFrame
from .frames import render_frame as render_frame
from .gamma import GammaFit as GammaFit
from .gamma import fit_gamma_fringes as fit_gamma_fringes
from .gamma import fit_gamma_uniform as fit_gamma_uniform
from .io.calibration_file import load_calibration as load_calibration
from .io.calibration_file import save_calibration as save_calibration
from .io.captures import read_capture_folder as read_capture_folder
from .io.captures import write_capture_folder as write_capture_folder
from .patterns import FringeSpec as FringeSpec
from .patterns import fringe_gray as fringe_gray
from .patterns import fringe_profile as fringe_profile
from .patterns import precompensate_gamma as precompensate_gamma
from .phase import PhaseResult as PhaseResult
from .phase import data_modulation as data_modulation
from .phase import decode_set as decode_set
from .phase import saturation_count as saturation_count
from .phase import sinusoidal_phase as sinusoidal_phase
from .phase import triangular_2step as triangular_2step
from .phase import triangular_3step as triangular_3step
from .phase import wrapped_phase as wrapped_phase
from .process import decode_captures as decode_captures
from .reconstruct import CameraGeometry as CameraGeometry
from .reconstruct import height_errors as height_errors
from .reconstruct import points_from_height as points_from_height
from .rig.base import Rig as Rig
from .rig.base import RigBase as RigBase
from .rig.modify import modify_captures as modify_captures
from .rig.replay import ReplayRig as ReplayRig
from .rig.scenes import black_plate as black_plate
from .rig.scenes import checkerboard as checkerboard
from .rig.scenes import make_scene as make_scene
from .rig.scenes import white_plate as white_plate
from .rig.simulated import CameraModel as CameraModel
from .rig.simulated import Lighting as Lighting
from .rig.simulated import SimulatedRig as SimulatedRig
from .strategies import StrategyResult as StrategyResult
from .strategies import available_strategies as available_strategies
from .strategies import get_strategy as get_strategy
from .strategies.conventional import conventional as conventional
from .strategies.dpa import dpa as dpa
from .strategies.lpa import lpa as lpa
from .strategies.uniform import uniform as uniform
from .unwrap import absolute_phase as absolute_phase
from .unwrap import absolute_phase_from_centerline as absolute_phase_from_centerline
from .unwrap import detect_centerline as detect_centerline
from .unwrap import unwrap_spatial as unwrap_spatial
from .unwrap import unwrap_temporal as unwrap_temporal

__version__: str
