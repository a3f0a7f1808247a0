import { fireEvent, render, screen } from '@testing-library/react';
import { afterEach, beforeEach, describe, expect, it, vi } from 'vitest';
import { Header } from '@/app/Header';
import { useSettingsStore, type UiConfig } from '@/stores/settingsStore';
import { silence, speak } from './speech';

const BROWSER_VOICE: UiConfig = {
  deployment: 'dev',
  llm: 'rules',
  planner: 'rules',
  speech_input: false,
  speech_input_reason: null,
  speech_output_browser: true,
  camera: false,
};

/** jsdom has no speech synthesis: a stand-in that records what was said and cancelled. */
function fakeSynthesis() {
  const synthesis = { speak: vi.fn(), cancel: vi.fn() };
  class Utterance {
    constructor(readonly text: string) {}
  }
  vi.stubGlobal('speechSynthesis', synthesis);
  vi.stubGlobal('SpeechSynthesisUtterance', Utterance);
  const spoken = () => synthesis.speak.mock.calls.map(([u]) => (u as Utterance).text);
  return { synthesis, spoken };
}

describe('browser speech', () => {
  beforeEach(() => {
    localStorage.clear();
    useSettingsStore.setState({ config: BROWSER_VOICE, muted: false });
  });
  afterEach(() => vi.unstubAllGlobals());

  it('speaks the robot sentences when the brain speaks through the browser', () => {
    const { spoken } = fakeSynthesis();
    speak('I am at the kitchen.');
    expect(spoken()).toEqual(['I am at the kitchen.']);
  });

  it('stays silent when the robot speaks through its own speaker', () => {
    const { spoken } = fakeSynthesis();
    useSettingsStore.setState({ config: { ...BROWSER_VOICE, speech_output_browser: false } });
    speak('hello');
    expect(spoken()).toEqual([]);
  });

  it('does nothing, and does not throw, in a browser without speech synthesis', () => {
    expect(() => {
      speak('hello');
      silence();
    }).not.toThrow();
  });

  it('mute stops the current sentence, silences the next ones and is remembered', () => {
    const { synthesis, spoken } = fakeSynthesis();
    render(<Header />);
    fireEvent.click(screen.getByRole('button', { name: 'Mute' }));

    expect(synthesis.cancel).toHaveBeenCalledTimes(1); // the sentence being spoken stops now
    expect(localStorage.getItem('muted')).toBe('1');
    speak('Stopped.');
    expect(spoken()).toEqual([]);

    fireEvent.click(screen.getByRole('button', { name: 'Unmute' }));
    speak('Should I continue or abort?');
    expect(spoken()).toEqual(['Should I continue or abort?']);
    expect(localStorage.getItem('muted')).toBe('0');
  });

  it('offers no mute button when the browser does not speak', () => {
    fakeSynthesis();
    useSettingsStore.setState({ config: { ...BROWSER_VOICE, speech_output_browser: false } });
    render(<Header />);
    expect(screen.queryByRole('button', { name: 'Mute' })).toBeNull();
  });
});
