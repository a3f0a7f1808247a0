import { create } from 'zustand';

export interface UiConfig {
  deployment: string;
  llm: string;
  planner: string | null;
  planner_understanding?: string | null;
  llm_understanding?: string;
  speech_input: boolean;
  speech_input_reason: string | null;
  speech_input_name?: string | null; // the recognizer in use (issue 36)
  speech_output_browser: boolean;
  camera: boolean;
}

export type Theme = 'light' | 'dark';

interface SettingsStore {
  config: UiConfig | null;
  teachingArmed: boolean;
  muted: boolean;
  theme: Theme;
  setConfig: (config: UiConfig) => void;
  setTeaching: (armed: boolean) => void;
  setMuted: (muted: boolean) => void;
  setTheme: (theme: Theme) => void;
}

function initialTheme(): Theme {
  const saved = typeof localStorage !== 'undefined' ? localStorage.getItem('theme') : null;
  if (saved === 'light' || saved === 'dark') return saved;
  return typeof matchMedia !== 'undefined' && matchMedia('(prefers-color-scheme: dark)').matches ? 'dark' : 'light';
}

export const useSettingsStore = create<SettingsStore>()((set) => ({
  config: null,
  teachingArmed: false,
  muted: typeof localStorage !== 'undefined' && localStorage.getItem('muted') === '1',
  theme: initialTheme(),
  setConfig: (config) => set({ config }),
  setTeaching: (teachingArmed) => set({ teachingArmed }),
  setMuted: (muted) => {
    localStorage.setItem('muted', muted ? '1' : '0');
    set({ muted });
  },
  setTheme: (theme) => {
    localStorage.setItem('theme', theme);
    set({ theme });
  },
}));
